// The implementation of stop_signal.hpp: SIGINT / SIGTERM / SIGUSR1 for long runs.
#include "host/run/stop_signal.hpp"

#include <csignal>

namespace capsflow {

namespace {
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void capsflow_stop_handler(int sig) { g_stop_signal = sig; }
}  // namespace

void install_stop_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = capsflow_stop_handler;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;  // a second signal takes the default action (kills)
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  // Slurm's warning before a time limit (#SBATCH --signal=B:USR1@S), and what docs/sweeps.md lists beside them.
  sigaction(SIGUSR1, &sa, nullptr);
}
int stop_signal() { return static_cast<int>(g_stop_signal); }
void request_stop(int signal) { g_stop_signal = signal; }
void clear_stop_request() { g_stop_signal = 0; }

std::string signal_name(int signal) {
  switch (signal) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    case SIGQUIT: return "SIGQUIT";
    case SIGUSR1: return "SIGUSR1";
    default: return "signal " + std::to_string(signal);
  }
}

}  // namespace capsflow
