// The process group of data-parallel training: torchrun's environment, c10d's TCPStore rendezvous and Gloo's
// collectives, with every failure turned into an error that names the rank and what to look at.
//
// The collectives are Gloo's ring all-reduce and one-to-all broadcast, run in the calling thread on a full mesh of
// TCP pairs that c10d's TCPStore connects (through ProcessGroupGloo's GlooStore adapter) — the library under
// ProcessGroupGloo, without its worker-thread queue: on the 2-core development machine ProcessGroupGloo took 1.4–1.7
// ms per all-reduce of 10 or 80 000 floats between two processes, Gloo's ring called directly 0.11 and 0.40 ms
// (loopback round trip 18 µs); an update makes about 40 of them.
//
// The pairs are synchronous (Gloo's setSync): the rank's own thread reads its sockets, spinning or blocking
// (CollectiveWait), instead of Gloo's network thread reading them and waking it. With two ranks training on two cores
// that took an update's learning phase from 0.29–0.30 s to 0.22 s (bench/train_scaling_bench.py). A synchronous
// write blocks until the kernel holds the whole message, and in a ring every rank writes before it reads: each
// collective runs in pieces that fit a socket's send buffer (kPieceBytes), so no two ranks can block in each other's
// write.
#include "rmpmarl/rl/torch/distributed.h"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <sched.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <gloo/allreduce_ring.h>
#include <gloo/broadcast_one_to_all.h>
#include <gloo/rendezvous/context.h>
#include <gloo/transport/tcp/device.h>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include <map>
#include <tuple>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rl {

Collective::~Collective() = default;

namespace {

// an integer environment variable in [lo, hi]; nullopt when unset
std::optional<long> EnvInt(const char* name, long lo, long hi) {
  const char* v = std::getenv(name);
  if (v == nullptr) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(v, &end, 10);
  if (errno != 0 || end == v || *end != '\0' || x < lo || x > hi) {
    throw InputError(fmt::format("environment variable {}: expected an integer in [{}, {}], got '{}'", name, lo, hi,
                                 v));
  }
  return x;
}

// the CPUs this process may run on (its affinity mask, as taskset or a cpuset sets it; a CPU-time quota such as
// Docker's --cpus does not show here)
long UsableCpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) return std::max(CPU_COUNT(&set), 1);
  return std::max<long>(sysconf(_SC_NPROCESSORS_ONLN), 1);
}

class GlooCollective final : public Collective {
 public:
  explicit GlooCollective(const ProcessGroupOptions& o) : options_(o) {
    try {
      c10d::TCPStoreOptions store;
      store.port = static_cast<std::uint16_t>(o.master_port);
      store.isServer = o.rank == 0;
      store.numWorkers = o.world_size;
      store.waitWorkers = true;
      store.timeout = o.timeout;
      store_ = c10::make_intrusive<c10d::TCPStore>(o.master_addr, store);
      // the interface the other ranks reach this one on: GLOO_SOCKET_IFNAME's (as torch.distributed), else loopback
      // for a local group, else the address the host's name resolves to
      gloo::transport::tcp::attr attr;
      const bool local = o.master_addr == "127.0.0.1" || o.master_addr == "localhost";
      if (const char* iface = std::getenv("GLOO_SOCKET_IFNAME"); iface != nullptr && *iface != '\0') {
        attr.iface = iface;
      } else {
        attr.hostname = local ? "127.0.0.1" : Hostname();
      }
      auto device = gloo::transport::tcp::CreateDevice(attr);
      context_ = std::make_shared<gloo::rendezvous::Context>(o.rank, o.world_size);
      context_->setTimeout(o.timeout);
      c10d::ProcessGroupGloo::GlooStore gloo_store(store_);
      context_->connectFullMesh(gloo_store, device);
      for (int i = 0; i < o.world_size; ++i) {
        if (i != o.rank) context_->getPair(i)->setSync(true, o.wait == CollectiveWait::kPoll);
      }
      CheckSendBuffer();
    } catch (const std::exception& e) {
      throw InputError(fmt::format("rank {} of {}: cannot join the process group at {}:{} within {} s (is rank 0 "
                                   "running, and are MASTER_ADDR and MASTER_PORT the same on every rank?): {}",
                                   o.rank, o.world_size, o.master_addr, o.master_port,
                                   std::chrono::duration<double>(o.timeout).count(), FirstLine(e.what())));
    }
  }

  int rank() const override { return options_.rank; }
  int world_size() const override { return options_.world_size; }

  void AllReduceSum(torch::Tensor& tensor) override { Collect(kAllReduce, "all-reduce", tensor); }
  void Broadcast(torch::Tensor& tensor) override { Collect(kBroadcast, "broadcast", tensor); }

 private:
  enum Op { kAllReduce, kBroadcast };
  // the algorithms bound to a buffer of one op, type and size, one per piece of at most kPieceBytes, made once
  // (every rank makes them in the same order, as they call the same collectives in the same order): registering a
  // ring's buffers costs more than running it
  struct Slot {
    torch::Tensor buffer;
    std::vector<std::unique_ptr<gloo::Algorithm>> pieces;
    void Run() {
      for (auto& piece : pieces) piece->run();
    }
  };
  template <typename T>
  static std::unique_ptr<gloo::Algorithm> Make(Op op, const std::shared_ptr<gloo::Context>& context, T* data,
                                               int count) {
    if (op == kAllReduce) return std::make_unique<gloo::AllreduceRing<T>>(context, std::vector<T*>{data}, count);
    return std::make_unique<gloo::BroadcastOneToAll<T>>(context, std::vector<T*>{data}, count, /*rootRank=*/0);
  }

  void Collect(Op op, const char* what, torch::Tensor& tensor) {
    const torch::ScalarType type = tensor.scalar_type();
    if (!tensor.device().is_cpu() || (type != torch::kFloat && type != torch::kDouble && type != torch::kLong)) {
      throw std::invalid_argument(fmt::format("Collective::{}: expected a CPU tensor of float, double or int64, got "
                                              "{}", what, tensor.toString()));
    }
    const int64_t n = tensor.numel();
    if (n == 0) return;
    Slot& slot = SlotFor(op, what, type, n);
    slot.buffer.copy_(tensor.reshape({-1}));
    Run(what, [&] { slot.Run(); });
    // the ring adds the ranks' buffers in a different order on each rank: with two the sums are the same bits
    // (a + b = b + a), with more they may differ in the last bits, so every rank takes rank 0's
    if (op == kAllReduce && options_.world_size > 2) {
      Slot& same = SlotFor(kBroadcast, what, type, n);
      same.buffer.copy_(slot.buffer);
      Run(what, [&] { same.Run(); });
      slot.buffer.copy_(same.buffer);
    }
    tensor.copy_(slot.buffer.view(tensor.sizes()));
  }

  // the slot of (op, type, size), its buffer and algorithms made on first use
  Slot& SlotFor(Op op, const char* what, torch::ScalarType type, int64_t n) {
    Slot& slot = slots_[{op, static_cast<int>(type), n}];
    if (!slot.pieces.empty()) return slot;
    slot.buffer = torch::zeros({n}, torch::TensorOptions().dtype(type));
    const int64_t per_piece = kPieceBytes / static_cast<int64_t>(slot.buffer.element_size());
    try {
      Run(what, [&] {
        for (int64_t at = 0; at < n; at += per_piece) {
          const int count = static_cast<int>(std::min(per_piece, n - at));
          auto add = [&](auto* data) { slot.pieces.push_back(Make(op, context_, data + at, count)); };
          if (type == torch::kFloat) add(slot.buffer.data_ptr<float>());
          if (type == torch::kDouble) add(slot.buffer.data_ptr<double>());
          if (type == torch::kLong) add(slot.buffer.data_ptr<int64_t>());
        }
      });
    } catch (...) {
      slot.pieces.clear();  // never taken for a whole set later
      throw;
    }
    return slot;
  }

  template <typename F>
  void Run(const char* what, F&& f) {
    try {
      f();
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format(
          "rank {} of {}: the {} failed: another rank died, hung for more than {} s, or the network between them "
          "failed ({}); the run resumes from its last checkpoint with --resume", options_.rank, options_.world_size,
          what, std::chrono::duration<double>(options_.timeout).count(), FirstLine(e.what())));
    }
  }
  static std::string FirstLine(const std::string& s) { return s.substr(0, s.find('\n')); }
  static std::string Hostname() {
    char name[256] = {};
    if (gethostname(name, sizeof(name) - 1) != 0) return "127.0.0.1";
    return name;
  }

  // the largest piece of a collective: a message a synchronous write hands to the kernel without waiting for the peer
  // to read. Gloo asks for a send buffer of the message's size, which Linux grants up to net.core.wmem_max and doubles
  // for its bookkeeping; 192 KiB fits Linux's default (208 KiB) and sends the paper network's gradient (90 000
  // floats) in two pieces (each piece costs a handshake: three pieces made an update 5 % slower). The same on every
  // rank, whatever its host: the ranks must cut a collective into the same pieces.
  static constexpr int64_t kPieceBytes = 192 * 1024;

  // a warning when this host grants less than a piece
  void CheckSendBuffer() const {
    int64_t wmem_max = -1;
    if (std::ifstream f("/proc/sys/net/core/wmem_max"); f) f >> wmem_max;
    if (wmem_max >= 0 && wmem_max < kPieceBytes) {
      fmt::print(stderr, "rmpmarl: warning: rank {}: net.core.wmem_max is {} bytes, below the {} bytes of a "
                         "collective's piece; the ranks may block each other until the timeout (raise it: sysctl -w "
                         "net.core.wmem_max=212992)\n", options_.rank, wmem_max, kPieceBytes);
    }
  }

  ProcessGroupOptions options_;
  c10::intrusive_ptr<c10d::Store> store_;
  std::shared_ptr<gloo::rendezvous::Context> context_;
  std::map<std::tuple<int, int, int64_t>, Slot> slots_;
};

}  // namespace

std::optional<ProcessGroupOptions> ProcessGroupFromEnvironment() {
  const std::optional<long> world = EnvInt("WORLD_SIZE", 1, 4096);
  if (!world) return std::nullopt;
  ProcessGroupOptions o;
  o.world_size = static_cast<int>(*world);
  const std::optional<long> rank = EnvInt("RANK", 0, o.world_size - 1);
  if (!rank) throw InputError(fmt::format("environment variable RANK: expected it with WORLD_SIZE={}, got none", *world));
  o.rank = static_cast<int>(*rank);
  o.local_rank = static_cast<int>(EnvInt("LOCAL_RANK", 0, 4095).value_or(o.rank));
  if (const char* addr = std::getenv("MASTER_ADDR"); addr != nullptr && *addr != '\0') o.master_addr = addr;
  else if (o.world_size > 1) throw InputError("environment variable MASTER_ADDR: expected rank 0's host, got none");
  o.master_port = static_cast<int>(EnvInt("MASTER_PORT", 1, 65535).value_or(29500));
  if (const std::optional<long> t = EnvInt("RMPMARL_DIST_TIMEOUT", 1, 86400)) o.timeout = std::chrono::seconds(*t);
  if (const char* w = std::getenv("RMPMARL_DIST_WAIT"); w != nullptr && *w != '\0') {
    const std::string wait = w;
    if (wait != "poll" && wait != "block") {
      throw InputError(fmt::format("environment variable RMPMARL_DIST_WAIT: expected 'poll' or 'block', got '{}'",
                                   wait));
    }
    o.wait = wait == "poll" ? CollectiveWait::kPoll : CollectiveWait::kBlock;
  } else {
    const long local_world = EnvInt("LOCAL_WORLD_SIZE", 1, 4096).value_or(o.world_size);
    o.wait = local_world <= UsableCpus() ? CollectiveWait::kPoll : CollectiveWait::kBlock;
  }
  return o;
}

std::unique_ptr<Collective> JoinProcessGroup(const ProcessGroupOptions& options) {
  if (options.world_size < 1 || options.rank < 0 || options.rank >= options.world_size) {
    throw InputError(fmt::format("process group: expected 0 <= rank < world size, got rank {} of {}", options.rank,
                                 options.world_size));
  }
  // a peer that dies closes its sockets: a write to one would raise SIGPIPE, whose default action ends this rank at
  // once, without the message naming what failed. Ignored, the write fails with EPIPE, the collective throws, and
  // the rank ends with that message (Python's interpreter ignores SIGPIPE for the same reason).
  std::signal(SIGPIPE, SIG_IGN);
  return std::make_unique<GlooCollective>(options);
}

int FreeLocalPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw std::runtime_error(fmt::format("cannot open a socket: {}", std::strerror(errno)));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const std::string why = std::strerror(errno);
    close(fd);
    throw std::runtime_error(fmt::format("cannot find a free local port: {}", why));
  }
  close(fd);
  return ntohs(addr.sin_port);
}

}  // namespace rmpmarl::rl
