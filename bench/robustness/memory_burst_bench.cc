// waymark-memory-burst: a burst of large, useless requests against a running server, as a
// robustness campaign sends them (issue 21: the server's resident memory stayed at the burst's
// peak for good), and the server's resident memory before, at the end of the burst and after it
// went idle (VmRSS, client/load/server_usage.h).
//
//   waymark-memory-burst --server HOST:PORT --pid PID [--clients 8] [--requests 40] [--mb 8]
//                        [--idle-seconds 20]
//
// Every client sends --requests EnrollView calls, each with --mb MiB of random bytes as the image
// (not an image: refused with INVALID_ARGUMENT after the server received, copied and tried to
// decode it), all clients at once. Run it against a server started with --insecure-dev, beside
// a server without the change being measured, in the same session.

#include <grpcpp/grpcpp.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "client/load/server_usage.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace {

double ResidentMb(int pid) {
  absl::StatusOr<waymark::cli::ProcessMemory> memory = waymark::cli::ReadProcessMemory(pid);
  return memory.ok() ? static_cast<double>(memory->rss_bytes) / (1 << 20) : -1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"A burst of large refused requests; the server's resident memory around it"};
  std::string server;
  int pid = 0, clients = 8, requests = 40, mb = 8;
  double idle_seconds = 20;
  app.add_option("--server", server, "HOST:PORT of a server with --insecure-dev")->required();
  app.add_option("--pid", pid, "the server's process id")->required();
  app.add_option("--clients", clients)->capture_default_str();
  app.add_option("--requests", requests, "per client")->capture_default_str();
  app.add_option("--mb", mb, "MiB of bytes per request")->capture_default_str();
  app.add_option("--idle-seconds", idle_seconds)->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(64 << 20);
  const double start = ResidentMb(pid);
  std::vector<std::thread> threads;
  std::vector<int> refused(clients, 0);
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      auto channel = grpc::CreateCustomChannel(server, grpc::InsecureChannelCredentials(), args);
      auto stub = waymark::v1::CrossingService::NewStub(channel);
      std::mt19937 random(c);
      std::string bytes(static_cast<size_t>(mb) << 20, '\0');
      for (char& b : bytes) b = static_cast<char>(random());
      for (int i = 0; i < requests; ++i) {
        waymark::v1::EnrollViewRequest request;
        request.set_database("burst");
        request.set_crossing("c");
        request.set_create_crossing(true);
        request.set_heading_deg(i % 360);
        request.mutable_image()->set_data(bytes);
        waymark::v1::EnrollViewResponse response;
        grpc::ClientContext context;
        context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
        if (!stub->EnrollView(&context, request, &response).ok()) ++refused[c];
      }
    });
  }
  for (std::thread& t : threads) t.join();
  const double burst = ResidentMb(pid);
  std::this_thread::sleep_for(std::chrono::duration<double>(idle_seconds));
  const double idle = ResidentMb(pid);
  int total_refused = 0;
  for (int r : refused) total_refused += r;
  std::printf(
      "resident MB: start %.0f, after the burst %.0f, after %.0f s idle %.0f "
      "(%d clients x %d requests x %d MiB, %d refused)\n",
      start, burst, idle_seconds, idle, clients, requests, mb, total_refused);
  return 0;
}
