// Measures BlobClient throughput over loopback: starts a BlobService on
// 127.0.0.1, uploads a file of --bytes (default 64 MiB) and downloads it
// back, and prints {"bytes":..., "uploadMBps":..., "downloadMBps":...}.
// Upload time includes the client's hashing and the server's fsync;
// download time includes the server's and the client's hash checks.
//
//   pf_blob_bench [--bytes N] [--dir DIR]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/file_util.h"
#include "grpcpp/security/server_credentials.h"
#include "grpcpp/server.h"
#include "grpcpp/server_builder.h"
#include "rpc/blob_transfer.h"
#include "rpc/grpc_status.h"
#include "server/blobs/blob_service.h"
#include "server/blobs/blob_store.h"
#include "tests/test_util.h"

namespace {

using pf::SecondsSince;

int Fail(const std::string& message) {
  std::fprintf(stderr, "pf_blob_bench: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  int64_t bytes = int64_t{64} << 20;
  std::string dir;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--bytes" && i + 1 < argc) {
      if (!absl::SimpleAtoi(argv[++i], &bytes) || bytes <= 0) {
        return Fail("--bytes: expected a positive integer");
      }
    } else if (arg == "--dir" && i + 1 < argc) {
      dir = argv[++i];
    } else {
      return Fail(absl::StrCat("unknown argument '", arg,
                               "'; usage: pf_blob_bench [--bytes N] [--dir DIR]"));
    }
  }
  if (dir.empty()) dir = pf::testing::MakeTempDir("pf_blob_bench");

  // Random content, so nothing compresses or dedups.
  std::string content(static_cast<size_t>(bytes), '\0');
  std::mt19937_64 random(42);
  for (size_t i = 0; i + 8 <= content.size(); i += 8) {
    const uint64_t word = random();
    std::memcpy(&content[i], &word, 8);
  }
  const std::string input = dir + "/input.bin";
  const std::string output = dir + "/output.bin";
  if (absl::Status s = pf::WriteFileAtomic(input, content); !s.ok()) {
    return Fail(std::string(s.message()));
  }

  pf::BlobStore store(dir + "/blobs");
  pf::BlobServiceImpl service(&store, /*max_upload_bytes=*/0);
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) return Fail("cannot start the server on 127.0.0.1");
  const std::string address = absl::StrCat("127.0.0.1:", port);
  pf::BlobClient client(pf::MakeChannel(address), address);

  auto start = std::chrono::steady_clock::now();
  absl::StatusOr<pointforward::v1::Digest> digest = client.UploadFile(input);
  const double upload_s = SecondsSince(start);
  if (!digest.ok()) return Fail(std::string(digest.status().message()));

  start = std::chrono::steady_clock::now();
  absl::Status downloaded = client.DownloadToFile(digest->sha256(), output);
  const double download_s = SecondsSince(start);
  if (!downloaded.ok()) return Fail(std::string(downloaded.message()));
  server->Shutdown();

  std::error_code ec;
  if (std::filesystem::file_size(output, ec) != static_cast<uintmax_t>(bytes)) {
    return Fail("downloaded file has the wrong size");
  }
  const double mb = static_cast<double>(bytes) / 1e6;
  std::printf("{\"bytes\": %lld, \"uploadMBps\": %.1f, \"downloadMBps\": %.1f}\n",
              static_cast<long long>(bytes), mb / upload_s, mb / download_s);
  return 0;
}
