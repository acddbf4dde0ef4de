#include "bench/robustness/hostile_campaign_server.h"

#include <signal.h>
#include <sqlite3.h>

#include <chrono>
#include <map>
#include <regex>

#include "absl/strings/str_split.h"
#include "client/load/server_usage.h"

namespace waymark::bench::hostile {
namespace {

double Mb(int64_t bytes) { return static_cast<double>(bytes) / (1 << 20); }

// The rows of `sql` (each row's columns joined by '|'), or the error.
absl::StatusOr<std::vector<std::string>> Query(sqlite3* db, const std::string& sql) {
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement, nullptr) != SQLITE_OK) {
    return absl::InternalError(sqlite3_errmsg(db));
  }
  std::vector<std::string> rows;
  int rc;
  while ((rc = sqlite3_step(statement)) == SQLITE_ROW) {
    std::string row;
    for (int c = 0; c < sqlite3_column_count(statement); ++c) {
      const unsigned char* text = sqlite3_column_text(statement, c);
      row += (c ? "|" : "") + std::string(text ? reinterpret_cast<const char*>(text) : "NULL");
    }
    rows.push_back(row);
  }
  sqlite3_finalize(statement);
  if (rc != SQLITE_DONE) return absl::InternalError(sqlite3_errmsg(db));
  return rows;
}

}  // namespace

absl::StatusOr<std::unique_ptr<WatchedServer>> WatchedServer::Start(const std::string& db,
                                                                    bool auth) {
  std::unique_ptr<WatchedServer> server(new WatchedServer(db, auth));
  if (absl::Status s = server->Launch("127.0.0.1:0"); !s.ok()) return s;
  server->sampler_ = std::thread([s = server.get()] {
    while (!s->stop_) {
      s->Sample();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  return server;
}

WatchedServer::~WatchedServer() {
  stop_ = true;
  if (sampler_.joinable()) sampler_.join();
}

absl::Status WatchedServer::Launch(const std::string& listen) {
  absl::StatusOr<std::unique_ptr<testing::ServerProcess>> started =
      auth_ ? testing::ServerProcess::StartWithAuth(testing::ServerBinary(), db_, {}, listen)
            : testing::ServerProcess::Start(testing::ServerBinary(), db_, {}, listen);
  if (!started.ok()) return started.status();
  std::lock_guard<std::mutex> lock(mutex_);
  process_ = *std::move(started);
  address_ = process_->address();
  exit_code_.reset();
  alive_ = true;
  return absl::OkStatus();
}

bool WatchedServer::CheckRunningLocked() {
  if (process_ == nullptr || !alive_) return false;
  if (!process_->Running()) {
    alive_ = false;
    exit_code_ = process_->WaitForExit(absl::ZeroDuration());
  }
  return alive_;
}

void WatchedServer::Sample() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!CheckRunningLocked()) return;
  absl::StatusOr<cli::ProcessMemory> memory = cli::ReadProcessMemory(process_->pid());
  if (!memory.ok()) return;
  const double mb = Mb(memory->rss_bytes);
  double peak = peak_mb_.load();
  while (mb > peak && !peak_mb_.compare_exchange_weak(peak, mb)) {}
}

bool WatchedServer::Alive() {
  if (!alive_) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  return CheckRunningLocked();
}

bool WatchedServer::DiesWithin(std::chrono::milliseconds wait) {
  const auto until = std::chrono::steady_clock::now() + wait;
  while (Alive()) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

std::optional<int> WatchedServer::ExitCode() {
  Alive();
  std::lock_guard<std::mutex> lock(mutex_);
  return exit_code_;
}

std::string WatchedServer::Log() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return process_ == nullptr ? "" : process_->Log();
}

absl::Status WatchedServer::Restart() { return Launch(address_); }

int WatchedServer::Terminate() {
  std::lock_guard<std::mutex> lock(mutex_);
  alive_ = false;
  if (exit_code_.has_value()) return *exit_code_;
  exit_code_ = process_->Stop(SIGTERM);
  return *exit_code_;
}

double WatchedServer::RssMb() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!alive_) return -1;
  absl::StatusOr<cli::ProcessMemory> memory = cli::ReadProcessMemory(process_->pid());
  return memory.ok() ? Mb(memory->rss_bytes) : -1;
}

double WatchedServer::KernelPeakMb() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!alive_) return -1;
  absl::StatusOr<cli::ProcessMemory> memory = cli::ReadProcessMemory(process_->pid());
  return memory.ok() ? Mb(memory->peak_rss_bytes) : -1;
}

void WatchedServer::ResetPeak() { peak_mb_ = RssMb(); }

nlohmann::json CheckSqlite(const std::string& path) {
  sqlite3* db = nullptr;
  nlohmann::json out = {{"file", path}};
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    out["error"] = db ? sqlite3_errmsg(db) : "cannot open";
    sqlite3_close(db);
    return out;
  }
  absl::StatusOr<std::vector<std::string>> integrity = Query(db, "PRAGMA integrity_check");
  absl::StatusOr<std::vector<std::string>> foreign = Query(db, "PRAGMA foreign_key_check");
  out["integrity_check"] = integrity.ok() ? nlohmann::json(*integrity)
                                          : nlohmann::json(integrity.status().ToString());
  out["integrity_ok"] = integrity.ok() && integrity->size() == 1 && (*integrity)[0] == "ok";
  out["foreign_key_violations"] =
      foreign.ok() ? nlohmann::json(foreign->size()) : nlohmann::json(foreign.status().ToString());
  if (foreign.ok() && !foreign->empty()) {
    out["foreign_key_examples"] =
        std::vector<std::string>(foreign->begin(), foreign->begin() + std::min<size_t>(5, foreign->size()));
  }
  out["foreign_keys_ok"] = foreign.ok() && foreign->empty();
  nlohmann::json rows = nlohmann::json::object();
  if (auto tables = Query(db, "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name");
      tables.ok()) {
    for (const std::string& table : *tables) {
      auto count = Query(db, "SELECT COUNT(*) FROM \"" + table + "\"");
      if (count.ok() && !count->empty()) rows[table] = std::stoll((*count)[0]);
    }
  }
  out["rows"] = rows;
  sqlite3_close(db);
  return out;
}

nlohmann::json SummarizeLog(const std::string& log) {
  // "[2026-12-03 02:39:42.582] [waymark] [info] text": the timestamp, logger and level.
  static const std::regex kPrefix(R"(^\[[^\]]*\] \[[^\]]*\] \[([a-z]+)\] )");
  static const std::regex kVolatile(R"(( ms| request_id| peer| robot)=("[^"]*"|\S+))");
  std::map<std::string, int64_t> by_level;
  std::map<std::string, int64_t> serious;  // warning and above, by normalised text
  std::vector<std::string> examples;
  for (absl::string_view line : absl::StrSplit(log, '\n', absl::SkipEmpty())) {
    std::smatch prefix;
    const std::string raw(line);
    const bool ours = std::regex_search(raw, prefix, kPrefix);
    const std::string level = ours ? prefix[1].str() : "other";  // libprotobuf, gRPC core, ...
    const std::string text = ours ? prefix.suffix().str() : raw;
    ++by_level[level];
    if (level == "info" || level == "debug" || level == "trace") continue;
    ++serious[std::regex_replace(text, kVolatile, "").substr(0, 300)];
    if (examples.size() < 20) examples.emplace_back(line.substr(0, 600));
  }
  return {{"lines_by_level", by_level}, {"warnings_and_errors", serious}, {"examples", examples}};
}

}  // namespace waymark::bench::hostile
