#pragma once
// SIGINT / SIGTERM / SIGUSR1 for long runs: the first signal asks the run loop to checkpoint and stop at the next step
// boundary; a second one takes the default action (kills), so a stuck process can still be stopped.
#include <string>

namespace capsflow {

void install_stop_signal_handlers();
// The signal received (0: none). request_stop is what the handler calls; tests may call it too.
int stop_signal();
void request_stop(int signal);
void clear_stop_request();
// "SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT", "SIGUSR1", else "signal N": how messages name a signal that stopped us.
std::string signal_name(int signal);

}  // namespace capsflow
