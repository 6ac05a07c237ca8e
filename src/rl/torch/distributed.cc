// The process group of data-parallel training: torchrun's environment, c10d's TCPStore rendezvous and Gloo
// collectives, with every failure turned into an error that names the rank and what to look at.
#include "rmpmarl/rl/torch/distributed.h"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

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
      auto gloo = c10d::ProcessGroupGloo::Options::create(o.timeout);
      // the interface that reaches the master: loopback for a local group, the host's address across machines
      gloo->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname(
          o.master_addr == "127.0.0.1" || o.master_addr == "localhost" ? "127.0.0.1" : Hostname()));
      group_ = c10::make_intrusive<c10d::ProcessGroupGloo>(store_, o.rank, o.world_size, gloo);
    } catch (const std::exception& e) {
      throw InputError(fmt::format("rank {} of {}: cannot join the process group at {}:{} within {} s (is rank 0 "
                                   "running, and are MASTER_ADDR and MASTER_PORT the same on every rank?): {}",
                                   o.rank, o.world_size, o.master_addr, o.master_port,
                                   std::chrono::duration<double>(o.timeout).count(), FirstLine(e.what())));
    }
  }

  int rank() const override { return options_.rank; }
  int world_size() const override { return options_.world_size; }

  void AllReduceSum(torch::Tensor& tensor) override {
    Run("all-reduce", [&] {
      std::vector<at::Tensor> t{tensor};
      group_->allreduce(t)->wait();
    });
  }
  void Broadcast(torch::Tensor& tensor) override {
    Run("broadcast", [&] {
      std::vector<at::Tensor> t{tensor};
      group_->broadcast(t)->wait();
    });
  }

 private:
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

  ProcessGroupOptions options_;
  c10::intrusive_ptr<c10d::Store> store_;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> group_;
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
  return o;
}

std::unique_ptr<Collective> JoinProcessGroup(const ProcessGroupOptions& options) {
  if (options.world_size < 1 || options.rank < 0 || options.rank >= options.world_size) {
    throw InputError(fmt::format("process group: expected 0 <= rank < world size, got rank {} of {}", options.rank,
                                 options.world_size));
  }
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
