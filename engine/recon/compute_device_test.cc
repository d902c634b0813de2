// Tests of --device parsing and of what this build can run.
#include "engine/recon/compute_device.h"

#include <gtest/gtest.h>

#include <string>

namespace pf {
namespace {

TEST(ComputeDevice, ParsesCpuCudaAndCudaN) {
  absl::StatusOr<ComputeDevice> cpu = ParseComputeDevice("cpu", "--device");
  ASSERT_TRUE(cpu.ok()) << cpu.status();
  EXPECT_EQ(cpu->kind, ComputeDevice::Kind::kCpu);
  EXPECT_EQ(cpu->ToString(), "cpu");

  absl::StatusOr<ComputeDevice> cuda = ParseComputeDevice("cuda", "--device");
  ASSERT_TRUE(cuda.ok()) << cuda.status();
  EXPECT_EQ(cuda->kind, ComputeDevice::Kind::kCuda);
  EXPECT_EQ(cuda->index, 0);
  EXPECT_EQ(cuda->ToString(), "cuda:0");

  absl::StatusOr<ComputeDevice> third = ParseComputeDevice("cuda:2", "--device");
  ASSERT_TRUE(third.ok()) << third.status();
  EXPECT_EQ(third->index, 2);
  EXPECT_EQ(third->ToString(), "cuda:2");
}

TEST(ComputeDevice, RejectsOtherSpellingsNamingTheField) {
  for (const char* bad : {"gpu", "", "cuda:", "cuda:x", "cuda:-1", "cuda:1x", "CPU", "cuda:0:1"}) {
    absl::StatusOr<ComputeDevice> device = ParseComputeDevice(bad, "options.device");
    ASSERT_FALSE(device.ok()) << bad;
    EXPECT_EQ(device.status().code(), absl::StatusCode::kInvalidArgument) << bad;
    const std::string message(device.status().message());
    EXPECT_NE(message.find("options.device"), std::string::npos) << message;
    EXPECT_NE(message.find("cuda:N"), std::string::npos) << message;
  }
}

TEST(ComputeDevice, CpuIsAlwaysAvailable) {
  EXPECT_TRUE(CheckComputeDevice(ComputeDevice{}, "--device").ok());
}

TEST(ComputeDevice, AGpuThisProcessCannotUseIsRefusedSayingWhy) {
  // GPU 64 exists on no machine we run on; a GPU-less build refuses any.
  const ComputeDevice gpu{ComputeDevice::Kind::kCuda, 64};
  const absl::Status status = CheckComputeDevice(gpu, "--device");
  EXPECT_EQ(status.code(), absl::StatusCode::kFailedPrecondition) << status;
  const std::string message(status.message());
  EXPECT_NE(message.find("--device: 'cuda:64' is not available"), std::string::npos) << message;
  if (!HaveTensorBackend()) {
    EXPECT_NE(message.find("no LibTorch"), std::string::npos) << message;
  }
}

TEST(ComputeDevice, DescribesTheBackend) {
  const std::string description = TensorBackendDescription();
  EXPECT_EQ(description.rfind(HaveTensorBackend() ? "LibTorch " : "none", 0), 0u) << description;
}

}  // namespace
}  // namespace pf
