#include "client/common/stop_signals.h"

#include <csignal>
#include <cstdlib>

namespace waymark::cli {
namespace {

std::atomic<bool> g_stop{false};
std::atomic<bool> g_recognize{false};
struct sigaction g_old_int, g_old_term, g_old_usr1;

extern "C" void OnStopSignal(int signal) {
  if (signal == SIGINT && g_stop.load()) std::_Exit(130);  // second Ctrl-C: give up at once
  g_stop.store(true);
}

extern "C" void OnRecognizeSignal(int) { g_recognize.store(true); }

void Install(int signal, void (*handler)(int), struct sigaction* old) {
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  sigaction(signal, &action, old);
}

}  // namespace

StopSignals::StopSignals() {
  g_stop.store(false);
  g_recognize.store(false);
  Install(SIGINT, OnStopSignal, &g_old_int);
  Install(SIGTERM, OnStopSignal, &g_old_term);
  Install(SIGUSR1, OnRecognizeSignal, &g_old_usr1);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &g_old_int, nullptr);
  sigaction(SIGTERM, &g_old_term, nullptr);
  sigaction(SIGUSR1, &g_old_usr1, nullptr);
}

const std::atomic<bool>& StopSignals::stop_requested() const { return g_stop; }
void StopSignals::RequestStop() { g_stop.store(true); }
bool StopSignals::TakeRecognizeRequest() { return g_recognize.exchange(false); }

}  // namespace waymark::cli
