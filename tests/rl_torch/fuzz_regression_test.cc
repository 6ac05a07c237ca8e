// Regression inputs of the fuzz targets (tests/data/fuzz/<loader>/): each one, fed to its loader the way the fuzzer
// fed it (fuzz/fuzz_loaders.h), ends in a loaded object or an InputError — never another exception or a crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fuzz_loaders.h"

namespace rmpmarl::fuzz {
namespace {

namespace fs = std::filesystem;

class FuzzRegressionTest : public ::testing::TestWithParam<Loader> {};

TEST_P(FuzzRegressionTest, EveryInputLoadsOrThrowsInputError) {
  const fs::path dir = fs::path(RMPMARL_TEST_DATA_DIR) / "fuzz" / std::string(LoaderName(GetParam()));
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  int inputs = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    SCOPED_TRACE(entry.path().string());
    EXPECT_NO_THROW(LoadFuzzInput(GetParam(), bytes.str()));
    ++inputs;
  }
  EXPECT_GT(inputs, 0) << "no regression input in " << dir;
}

INSTANTIATE_TEST_SUITE_P(Loaders, FuzzRegressionTest,
                         ::testing::Values(Loader::kRobot, Loader::kTaskConfig, Loader::kTrainConfig,
                                           Loader::kRmpflowConfig, Loader::kCheckpoint, Loader::kPolicy),
                         [](const ::testing::TestParamInfo<Loader>& info) {
                           return std::string(LoaderName(info.param));
                         });

}  // namespace
}  // namespace rmpmarl::fuzz
