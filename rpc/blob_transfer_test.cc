// BlobClient against a real BlobServiceImpl over gRPC on loopback: chunked
// uploads and downloads, skipped re-uploads, the upload limit, corruption on
// the server and an unreachable server.
#include "rpc/blob_transfer.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "grpcpp/security/server_credentials.h"
#include "grpcpp/server.h"
#include "grpcpp/server_builder.h"
#include "gtest/gtest.h"
#include "rpc/grpc_status.h"
#include "server/blobs/blob_service.h"
#include "server/blobs/blob_store.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace v1 = pointforward::v1;

constexpr int64_t kUploadLimit = 8 << 20;

// Deterministic pseudo-random bytes (xorshift), so chunks differ.
std::string RandomBytes(size_t size, uint64_t seed) {
  std::string bytes(size, '\0');
  uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
  for (size_t i = 0; i < size; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    bytes[i] = static_cast<char>(x >> 24);
  }
  return bytes;
}

// Returns a loopback TCP port that was free a moment ago (bound, then closed).
int UnusedPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  int port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0) {
    port = ntohs(address.sin_port);
  }
  ::close(fd);
  return port;
}

// The real BlobServiceImpl, with a count of the WriteBlob calls it served, so
// tests can tell an upload that was skipped from one that was sent.
class CountingBlobService final : public v1::BlobService::Service {
 public:
  CountingBlobService(BlobStore* store, int64_t max_upload_bytes)
      : impl_(store, max_upload_bytes) {}

  grpc::Status WriteBlob(grpc::ServerContext* context,
                         grpc::ServerReader<v1::WriteBlobRequest>* reader,
                         v1::WriteBlobResponse* response) override {
    ++write_calls_;
    return impl_.WriteBlob(context, reader, response);
  }
  grpc::Status ReadBlob(grpc::ServerContext* context, const v1::ReadBlobRequest* request,
                        grpc::ServerWriter<v1::ReadBlobResponse>* writer) override {
    return impl_.ReadBlob(context, request, writer);
  }
  grpc::Status FindMissingBlobs(grpc::ServerContext* context,
                                const v1::FindMissingBlobsRequest* request,
                                v1::FindMissingBlobsResponse* response) override {
    return impl_.FindMissingBlobs(context, request, response);
  }

  int write_calls() const { return write_calls_; }

 private:
  BlobServiceImpl impl_;
  std::atomic<int> write_calls_{0};
};

class BlobTransferTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("blob_transfer");
    store_ = std::make_unique<BlobStore>(dir_ + "/blobs");
    service_ = std::make_unique<CountingBlobService>(store_.get(), kUploadLimit);
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    ASSERT_GT(port_, 0);
    address_ = absl::StrCat("127.0.0.1:", port_);
    channel_ = MakeChannel(address_);
    client_ = std::make_unique<BlobClient>(channel_, address_);
  }

  void TearDown() override {
    if (server_) server_->Shutdown();
  }

  // Writes `content` to DIR/name and returns the path.
  std::string WriteInput(const std::string& name, const std::string& content) {
    const std::string path = dir_ + "/in/" + name;
    EXPECT_TRUE(WriteFileAtomic(path, content).ok());
    return path;
  }

  // Sends a raw WriteBlob and returns the response (for already_present).
  grpc::Status RawWrite(const v1::Digest& digest, const std::string& content,
                        v1::WriteBlobResponse* response) {
    auto stub = v1::BlobService::NewStub(channel_);
    grpc::ClientContext context;
    auto writer = stub->WriteBlob(&context, response);
    v1::WriteBlobRequest request;
    *request.mutable_digest() = digest;
    request.set_data(content);
    writer->Write(request);
    writer->WritesDone();
    return writer->Finish();
  }

  std::string dir_;
  std::unique_ptr<BlobStore> store_;
  std::unique_ptr<CountingBlobService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  std::string address_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<BlobClient> client_;
};

TEST_F(BlobTransferTest, UploadsInChunksAndDownloadsByteIdentical) {
  // 3.5 MiB: three full 1 MiB chunks and a half one.
  const std::string content = RandomBytes(3 * kBlobChunkBytes + kBlobChunkBytes / 2, 1);
  const std::string input = WriteInput("big.bin", content);

  absl::StatusOr<v1::Digest> digest = client_->UploadFile(input);
  ASSERT_TRUE(digest.ok()) << digest.status();
  EXPECT_EQ(digest->sha256(), Sha256Hex(content));
  EXPECT_EQ(digest->size_bytes(), static_cast<int64_t>(content.size()));
  // What the server stored is the content itself.
  EXPECT_EQ(store_->Get(digest->sha256()).value(), content);

  const std::string output = dir_ + "/out/sub/big.bin";
  ASSERT_TRUE(client_->DownloadToFile(digest->sha256(), output).ok());
  EXPECT_EQ(ReadFileToString(output).value(), content);
  // Nothing but the target is left in the output directory.
  int entries = 0;
  for (const auto& entry : fs::directory_iterator(dir_ + "/out/sub")) {
    EXPECT_EQ(entry.path().filename(), "big.bin");
    ++entries;
  }
  EXPECT_EQ(entries, 1);

  EXPECT_EQ(client_->DownloadBytes(digest->sha256()).value(), content);
}

TEST_F(BlobTransferTest, UploadBytesAndEmptyBlob) {
  const std::string content = RandomBytes(kBlobChunkBytes + 17, 2);
  absl::StatusOr<v1::Digest> digest = client_->UploadBytes(content);
  ASSERT_TRUE(digest.ok()) << digest.status();
  EXPECT_EQ(store_->Get(digest->sha256()).value(), content);

  absl::StatusOr<v1::Digest> empty = client_->UploadBytes("");
  ASSERT_TRUE(empty.ok()) << empty.status();
  EXPECT_EQ(empty->size_bytes(), 0);
  EXPECT_TRUE(store_->Contains(empty->sha256()));
  EXPECT_EQ(client_->DownloadBytes(empty->sha256()).value(), "");
}

TEST_F(BlobTransferTest, SecondUploadIsSkippedWhenServerHasTheBlob) {
  const std::string content = RandomBytes(2 * kBlobChunkBytes, 3);
  const std::string input = WriteInput("twice.bin", content);
  const v1::Digest first = client_->UploadFile(input).value();
  EXPECT_EQ(service_->write_calls(), 1);

  absl::StatusOr<v1::Digest> second = client_->UploadFile(input);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(second->sha256(), first.sha256());
  EXPECT_EQ(service_->write_calls(), 1);

  // A WriteBlob for a stored blob answers already_present.
  v1::WriteBlobResponse response;
  ASSERT_TRUE(RawWrite(first, content, &response).ok());
  EXPECT_TRUE(response.already_present());

  // UploadFiles uploads each distinct missing file once and skips the rest.
  const std::string other = WriteInput("other.bin", "other content");
  absl::StatusOr<std::vector<v1::Digest>> many = client_->UploadFiles({input, other, other});
  ASSERT_TRUE(many.ok()) << many.status();
  ASSERT_EQ(many->size(), 3u);
  EXPECT_EQ((*many)[0].sha256(), first.sha256());
  EXPECT_EQ((*many)[1].sha256(), Sha256Hex("other content"));
  EXPECT_EQ((*many)[2].sha256(), Sha256Hex("other content"));
  EXPECT_EQ(store_->Get(Sha256Hex("other content")).value(), "other content");
  // One raw write above, one for other.bin.
  EXPECT_EQ(service_->write_calls(), 3);
}

TEST_F(BlobTransferTest, UploadOverTheLimitIsRefusedNamingIt) {
  const std::string input = WriteInput("huge.bin", RandomBytes(kUploadLimit + 1, 4));
  absl::StatusOr<v1::Digest> digest = client_->UploadFile(input);
  ASSERT_FALSE(digest.ok());
  EXPECT_EQ(digest.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(digest.status().message(),
            absl::StrCat(input, ": digest.size_bytes: ", kUploadLimit + 1,
                         " bytes exceeds the upload limit of ", kUploadLimit,
                         " bytes (--max-upload-bytes)"));
  EXPECT_FALSE(store_->Contains(Sha256Hex(RandomBytes(kUploadLimit + 1, 4))));
}

TEST_F(BlobTransferTest, WrongAnnouncedDigestIsRefusedAndNothingKept) {
  v1::Digest digest;
  digest.set_sha256(Sha256Hex("promised"));
  digest.set_size_bytes(5);
  v1::WriteBlobResponse response;
  grpc::Status status = RawWrite(digest, "other", &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "digest.sha256: content hashes to " + Sha256Hex("other") +
                                        ", not " + Sha256Hex("promised"));
  EXPECT_FALSE(store_->Contains(Sha256Hex("promised")));
  EXPECT_FALSE(store_->Contains(Sha256Hex("other")));

  // A stream that ends early: the announced size is not reached.
  const std::string whole = RandomBytes(1000, 8);
  digest.set_sha256(Sha256Hex(whole));
  digest.set_size_bytes(1000);
  status = RawWrite(digest, whole.substr(0, 600), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "digest.size_bytes: 1000 bytes announced, 600 received");
  EXPECT_FALSE(store_->Contains(Sha256Hex(whole)));
  EXPECT_TRUE(fs::is_empty(dir_ + "/blobs/tmp"));

  // No digest in the first message.
  auto stub = v1::BlobService::NewStub(channel_);
  grpc::ClientContext context;
  auto writer = stub->WriteBlob(&context, &response);
  v1::WriteBlobRequest request;
  request.set_data("data without a digest");
  writer->Write(request);
  writer->WritesDone();
  status = writer->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "digest: missing in the first message");
}

TEST_F(BlobTransferTest, CancelledUploadLeavesNothing) {
  const std::string content = RandomBytes(3 * kBlobChunkBytes, 5);
  v1::Digest digest;
  digest.set_sha256(Sha256Hex(content));
  digest.set_size_bytes(static_cast<int64_t>(content.size()));
  auto stub = v1::BlobService::NewStub(channel_);
  grpc::ClientContext context;
  v1::WriteBlobResponse response;
  auto writer = stub->WriteBlob(&context, &response);
  v1::WriteBlobRequest request;
  *request.mutable_digest() = digest;
  request.set_data(content.substr(0, kBlobChunkBytes));
  ASSERT_TRUE(writer->Write(request));
  context.TryCancel();
  EXPECT_EQ(writer->Finish().error_code(), grpc::StatusCode::CANCELLED);
  server_->Shutdown();  // Waits for the handler to return.
  server_.reset();
  EXPECT_FALSE(store_->Contains(digest.sha256()));
  EXPECT_TRUE(fs::is_empty(dir_ + "/blobs/tmp"));
}

TEST_F(BlobTransferTest, CorruptedBlobOnServerGivesDataLossAndNoFile) {
  const std::string content = RandomBytes(2 * kBlobChunkBytes + 100, 6);
  const v1::Digest digest = client_->UploadBytes(content).value();
  const std::string stored = store_->PathOf(digest.sha256()).value();
  {
    std::fstream file(stored, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(kBlobChunkBytes + 5);
    file.put(static_cast<char>(content[kBlobChunkBytes + 5] ^ 1));
  }

  const std::string output = dir_ + "/out/corrupt.bin";
  absl::Status status = client_->DownloadToFile(digest.sha256(), output);
  EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss) << status;
  EXPECT_NE(std::string(status.message()).find(output), std::string::npos) << status;
  EXPECT_FALSE(fs::exists(output));
  EXPECT_TRUE(fs::is_empty(dir_ + "/out"));
  // The server dropped the bad copy: the blob now reads as missing.
  EXPECT_FALSE(store_->Contains(digest.sha256()));
  EXPECT_EQ(client_->DownloadBytes(digest.sha256()).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(BlobTransferTest, ReadBlobFromOffsetAndBadRequests) {
  const std::string content = RandomBytes(kBlobChunkBytes + 1000, 7);
  const v1::Digest digest = client_->UploadBytes(content).value();
  auto stub = v1::BlobService::NewStub(channel_);

  // From an offset: the rest of the blob, in chunks of at most 1 MiB.
  {
    grpc::ClientContext context;
    v1::ReadBlobRequest request;
    request.set_sha256(digest.sha256());
    request.set_offset(500);
    auto reader = stub->ReadBlob(&context, request);
    v1::ReadBlobResponse response;
    std::string received;
    while (reader->Read(&response)) {
      EXPECT_LE(static_cast<int64_t>(response.data().size()), kBlobChunkBytes);
      received += response.data();
    }
    ASSERT_TRUE(reader->Finish().ok());
    EXPECT_EQ(received, content.substr(500));
  }
  const auto read_status = [&stub](const std::string& sha256, int64_t offset) {
    grpc::ClientContext context;
    v1::ReadBlobRequest request;
    request.set_sha256(sha256);
    request.set_offset(offset);
    auto reader = stub->ReadBlob(&context, request);
    v1::ReadBlobResponse response;
    while (reader->Read(&response)) {
    }
    return reader->Finish();
  };
  grpc::Status beyond = read_status(digest.sha256(), digest.size_bytes() + 1);
  EXPECT_EQ(beyond.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(beyond.error_message(),
            absl::StrCat("offset: ", digest.size_bytes() + 1, " is outside the blob's ",
                         digest.size_bytes(), " bytes"));
  grpc::Status bad_hash = read_status("XYZ", 0);
  EXPECT_EQ(bad_hash.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(bad_hash.error_message(), "sha256: not 64 lowercase hex digits");
  const std::string absent = Sha256Hex("absent");
  grpc::Status missing = read_status(absent, 0);
  EXPECT_EQ(missing.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(missing.error_message(), "blob " + absent + " not found");

  // FindMissingBlobs names the bad entry.
  grpc::ClientContext context;
  v1::FindMissingBlobsRequest request;
  *request.add_digests() = digest;
  request.add_digests()->set_sha256("short");
  v1::FindMissingBlobsResponse response;
  grpc::Status find = stub->FindMissingBlobs(&context, request, &response);
  EXPECT_EQ(find.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(find.error_message(), "digests[1].sha256: not 64 lowercase hex digits");
}

TEST_F(BlobTransferTest, DownloadOfUnknownBlobIsNotFoundAndLeavesNoFile) {
  const std::string absent = Sha256Hex("nobody uploaded this");
  const std::string output = dir_ + "/out/absent.bin";
  absl::Status status = client_->DownloadToFile(absent, output);
  EXPECT_EQ(status.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(status.message(), output + ": blob " + absent + " not found");
  EXPECT_TRUE(fs::is_empty(dir_ + "/out"));
}

TEST_F(BlobTransferTest, MissingLocalFileIsNamed) {
  absl::StatusOr<v1::Digest> digest = client_->UploadFile(dir_ + "/no/such/file.png");
  EXPECT_EQ(digest.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(std::string(digest.status().message()).find(dir_ + "/no/such/file.png"),
            std::string::npos);
}

TEST(BlobTransferUnreachable, PortNobodyListensOnGivesUnavailable) {
  // Bind a port and close it again, so nothing listens there.
  const int port = UnusedPort();
  ASSERT_GT(port, 0);
  const std::string address = absl::StrCat("127.0.0.1:", port);
  BlobClient client(MakeChannel(address), address);
  absl::StatusOr<v1::Digest> digest = client.UploadBytes("hello");
  EXPECT_EQ(digest.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(std::string(digest.status().message()).rfind("server " + address + " unreachable: ", 0),
            0u)
      << digest.status();

  const std::string output = testing::MakeTempDir("blob_transfer") + "/x.bin";
  absl::Status download = client.DownloadToFile(Sha256Hex("hello"), output);
  EXPECT_EQ(download.code(), absl::StatusCode::kUnavailable);
  EXPECT_FALSE(fs::exists(output));
}

// A server that answers every ReadBlob with the wrong bytes: the client's own
// hash check must catch it.
class WrongBytesBlobService final : public v1::BlobService::Service {
 public:
  grpc::Status ReadBlob(grpc::ServerContext* /*context*/, const v1::ReadBlobRequest* /*request*/,
                        grpc::ServerWriter<v1::ReadBlobResponse>* writer) override {
    v1::ReadBlobResponse response;
    response.set_data("not what you asked for");
    writer->Write(response);
    return grpc::Status::OK;
  }
};

TEST(BlobTransferClientCheck, WrongBytesFromServerGiveDataLossAndNoFile) {
  WrongBytesBlobService service;
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  ASSERT_GT(port, 0);
  BlobClient client(MakeChannel(absl::StrCat("127.0.0.1:", port)));

  const std::string dir = testing::MakeTempDir("blob_transfer");
  const std::string wanted = Sha256Hex("what you asked for");
  const std::string output = dir + "/out.bin";
  absl::Status status = client.DownloadToFile(wanted, output);
  EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss);
  EXPECT_EQ(status.message(), output + ": blob " + wanted + ": downloaded content hashes to " +
                                  Sha256Hex("not what you asked for"));
  EXPECT_TRUE(fs::is_empty(dir));
  EXPECT_EQ(client.DownloadBytes(wanted).status().code(), absl::StatusCode::kDataLoss);
  server->Shutdown();
}

TEST(GrpcStatus, ConvertsCodesAndMessagesBothWays) {
  const absl::Status original = absl::NotFoundError("scenes/abc: not found");
  const grpc::Status converted = ToGrpc(original);
  EXPECT_EQ(converted.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(converted.error_message(), "scenes/abc: not found");
  EXPECT_EQ(FromGrpc(converted), original);
  EXPECT_TRUE(ToGrpc(absl::OkStatus()).ok());
  EXPECT_TRUE(FromGrpc(grpc::Status::OK).ok());
  for (int code = 1; code <= 16; ++code) {
    const absl::Status status(static_cast<absl::StatusCode>(code), "m");
    EXPECT_EQ(static_cast<int>(ToGrpc(status).error_code()), code);
    EXPECT_EQ(FromGrpc(ToGrpc(status)), status);
  }
  EXPECT_EQ(FromGrpc(grpc::Status(grpc::StatusCode::UNAVAILABLE, "refused"), "h:1").message(),
            "server h:1 unreachable: refused");
}

}  // namespace
}  // namespace pf
