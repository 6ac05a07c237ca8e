#pragma once
/// Data-parallel training across processes (docs/learning.md), as rsl_rl and Isaac Lab scale PPO: one process per
/// rank, each with its own environments; rank 0's initial parameters are broadcast, gradients are summed over the
/// ranks and divided by their number before every optimiser step, normalisers and advantage statistics are computed
/// over every rank's samples, and rank 0 alone writes files. The transport: c10d's TCPStore (libtorch) for the
/// rendezvous and Gloo's collectives, the library under ProcessGroupGloo (distributed.cc says why directly).
#include <torch/types.h>

#include <chrono>
#include <memory>
#include <optional>
#include <string>

namespace rmpmarl::rl {

/// What Ppo and the Trainer need of a process group. Every rank calls the same collectives in the same order.
class Collective {
 public:
  virtual ~Collective();
  virtual int rank() const = 0;
  virtual int world_size() const = 0;
  /// the element-wise sum over the ranks, in place, bit-identical on every rank (a contiguous CPU tensor of float,
  /// double or int64).
  virtual void AllReduceSum(torch::Tensor& tensor) = 0;
  /// rank 0's `tensor` on every rank, in place.
  virtual void Broadcast(torch::Tensor& tensor) = 0;
};

/// How a rank waits for its peers' data inside a collective. Either way the calling thread reads its sockets itself
/// (Gloo's synchronous pairs), without a hand-off to a network thread.
enum class CollectiveWait {
  kPoll,   ///< spin on the socket: the lowest latency, for no more ranks on a machine than it has cores
  kBlock,  ///< sleep in the socket read: for more ranks on a machine than cores, where a spinning rank would take the
           ///< core of the rank it waits for
};

/// Where a rank finds its group: torchrun's environment variables.
struct ProcessGroupOptions {
  int rank = 0;                       ///< RANK, in [0, world_size)
  int world_size = 1;                 ///< WORLD_SIZE
  int local_rank = 0;                 ///< LOCAL_RANK (this machine's index of the rank; reported only)
  std::string master_addr = "127.0.0.1";  ///< MASTER_ADDR: rank 0's host, which serves the TCPStore
  int master_port = 29500;            ///< MASTER_PORT
  /// a collective or the rendezvous that waits longer than this throws: a rank that died or hangs ends the others
  std::chrono::milliseconds timeout{60'000};
  CollectiveWait wait = CollectiveWait::kBlock;
};

/// the options from RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR, MASTER_PORT, RMPMARL_DIST_TIMEOUT (seconds) and
/// RMPMARL_DIST_WAIT (`poll` or `block`; by default poll when LOCAL_WORLD_SIZE — WORLD_SIZE when unset — is at most
/// the CPUs this process may run on); nullopt when WORLD_SIZE is unset. InputError naming the variable for a
/// malformed or inconsistent value.
std::optional<ProcessGroupOptions> ProcessGroupFromEnvironment();

/// joins the group (blocks until every rank has joined, at most `timeout`). InputError saying what failed.
std::unique_ptr<Collective> JoinProcessGroup(const ProcessGroupOptions& options);

/// a TCP port free on this machine now (bind to port 0), for a local group's MASTER_PORT.
int FreeLocalPort();

}  // namespace rmpmarl::rl
