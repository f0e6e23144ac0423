// When a run must stop (run_watch.hpp).
#include "avsp/results/run_watch.hpp"

#include <cctype>
#include <csignal>
#include <cstring>
#include <utility>

namespace avsp
{
namespace results
{
std::string nodeOfProcess(const std::string& process)
{
  std::string name = process;
  const std::size_t dash = name.rfind('-');
  if (dash != std::string::npos && dash + 1 < name.size())
  {
    bool digits = true;
    for (std::size_t k = dash + 1; k < name.size(); ++k)
      digits = digits && std::isdigit(static_cast<unsigned char>(name[k]));
    if (digits)
      name.erase(dash);
  }
  return name.empty() || name[0] == '/' ? name : "/" + name;
}

RunWatch::RunWatch(std::vector<std::string> watched) : watched_(std::move(watched))
{
  watched_set_.insert(watched_.begin(), watched_.end());
}

std::string RunWatch::lastError(const std::string& node) const
{
  const auto it = last_error_.find(node);
  return it == last_error_.end() ? std::string() : it->second;
}

std::optional<Abort> RunWatch::abort() const
{
  if (!failure_)
    return std::nullopt;
  Abort a = failure_->abort;
  if (failure_->with_last_error)
  {
    const std::string last = lastError(a.node);
    a.reason += last.empty() ? " (it logged no error)" : "; its last error: " + last;
  }
  return a;
}

void RunWatch::fail(const std::string& node, const std::string& reason, double sim_time)
{
  if (!failure_)
    failure_ = Failure{ Abort{ node, reason, sim_time }, false };
}

void RunWatch::failDied(const std::string& node, const std::string& what, double sim_time)
{
  if (!failure_)
    failure_ = Failure{ Abort{ node, what, sim_time }, true };
}

void RunWatch::noteError(const std::string& node, const std::string& text, bool fatal, double sim_time)
{
  last_error_[node] = text;
  if (fatal && isWatched(node))
    fail(node, "FATAL: " + text, sim_time);
}

void RunWatch::noteProcessDied(const std::string& process, std::optional<int> exit_code, double sim_time,
                               double wall_time)
{
  const std::string node = nodeOfProcess(process);
  const bool watched = isWatched(node);
  if (!watched && exit_code && *exit_code == 0)
    return;  // a helper that finished its job
  if (!watched && !exit_code)
  {
    // A helper's exit with an unknown code is its job done once the physics runs (start_gate
    // exits as soon as the clock moves); before that, it is a failure unless the clock starts.
    if (sim_time <= 0.0)
      exited_before_start_.emplace(node, wall_time);
    return;
  }
  std::string what;
  if (!exit_code)
    what = "exited before the run ended";
  else if (*exit_code < 0)
  {
    const char* name = strsignal(-*exit_code);
    what = "killed by signal " + std::to_string(-*exit_code) + (name ? std::string(" (") + name + ")" : "");
  }
  else
    what = "exited with code " + std::to_string(*exit_code) + " before the run ended";
  failDied(node, what, sim_time);
}

void RunWatch::noteTime(double sim_time, double wall_time)
{
  if (sim_time > 0.0)
  {
    exited_before_start_.clear();
    return;
  }
  for (const auto& [node, seen] : exited_before_start_)
    if (wall_time - seen >= kStartGrace)
    {
      failDied(node, "exited before the run started", sim_time);
      return;
    }
}

void RunWatch::notePing(const std::string& node, bool answered, const std::string& why, double sim_time)
{
  if (answered)
  {
    seen_alive_.insert(node);
    failed_pings_[node] = 0;
    return;
  }
  // Twice in a row: one XML-RPC call can time out on a loaded machine without the node being gone.
  if (isWatched(node) && seen_alive_.count(node) && ++failed_pings_[node] >= kFailedPings)
    failDied(node, "stopped answering (" + why + ")", sim_time);
}

}  // namespace results
}  // namespace avsp
