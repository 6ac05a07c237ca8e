// LD_PRELOAD shim for CheckpointKillTest: the Nth fsync of a checkpoint's temporary file
// (RMPMARL_KILL_AT_CHECKPOINT_WRITE=N) first cuts that file to half its bytes and then SIGKILLs the process — what a
// crash or an OOM kill in the middle of Trainer::SaveCheckpoint leaves behind.
#include <dlfcn.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

extern "C" int fsync(int fd) {
  using Fsync = int (*)(int);
  static const Fsync real = reinterpret_cast<Fsync>(dlsym(RTLD_NEXT, "fsync"));
  static int checkpoint_writes = 0;
  char link[64], target[4096];
  std::snprintf(link, sizeof(link), "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, target, sizeof(target) - 1);
  const char* kill_at = std::getenv("RMPMARL_KILL_AT_CHECKPOINT_WRITE");
  if (n > 0 && kill_at != nullptr) {
    target[n] = '\0';
    if (std::strstr(target, ".ckpt.tmp.") != nullptr && ++checkpoint_writes == std::atoi(kill_at)) {
      struct stat st {};
      if (fstat(fd, &st) == 0 && ftruncate(fd, st.st_size / 2) == 0) kill(getpid(), SIGKILL);
      std::abort();  // not reached
    }
  }
  return real(fd);
}
