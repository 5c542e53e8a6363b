#pragma once
// A child process for benchmarks and process tests: started from a program and its
// arguments (or a function), stopped with a signal and a deadline, killed if it outlives
// its owner, so that no orphan keeps ports, files or ctest's output pipe.

#include <sys/types.h>

#include <functional>
#include <string>
#include <vector>

namespace liloc {

class ChildProcess {
 public:
  // Runs `program` with `args` (argv[1...]); throws std::runtime_error if fork fails. A
  // program that cannot be executed exits 127.
  ChildProcess(const std::string& program, const std::vector<std::string>& args);
  // Runs `work` in the child, which exits 0 when it returns and 1 when it throws.
  explicit ChildProcess(const std::function<void()>& work);
  ~ChildProcess();  // SIGKILL and reaps it if it still runs
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool running();
  // Sends `signal` (if it still runs) and waits up to timeout_s for it to exit. Its exit
  // status, 128 + the signal if a signal ended it, or -1 if it had to be killed.
  int stop(int signal, double timeout_s);
  // Waits for it to exit on its own, up to timeout_s; then as stop().
  int wait(double timeout_s);

 private:
  // Reaps the child if it exited; true then, with its status in status_.
  bool reap(bool block);
  pid_t pid_ = -1;
  int status_ = -1;
};

}  // namespace liloc
