// The checkpoint loader behind checkpoint_fuzzer (needs librmpmarl_torch): the stored config, then the whole learner
// restored and its policy exported.
#include <string>

#include "fuzz_loaders.h"
#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::fuzz {

void LoadCheckpointInput(std::string_view bytes) {
  const std::string path = WriteTempFile("run.ckpt", WithValidChecksum(Loader::kCheckpoint, std::string(bytes)));
  rl::ReadCheckpointConfig(path);
  rl::ExportCheckpointPolicy(path, WriteTempFile("exported.rmpp", ""));
}

}  // namespace rmpmarl::fuzz
