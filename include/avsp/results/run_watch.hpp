#pragma once
/**
 * @file run_watch.hpp
 * @brief When a run must stop (no ROS): run_recorder feeds it what it sees of the run's
 *        processes (roslaunch's process lists, the master, /rosout) and asks whether, and why,
 *        the run has failed.
 *
 * A run fails when a watched node (one that must live for the whole run) exits, whatever its
 * exit code; when any other process of the run (a helper such as start_gate, which exits once
 * the physics runs) exits with a non-zero code, or, its code unknown, exits while the run has not
 * started and the clock does not start within kStartGrace; when a watched node logs a FATAL
 * message; or when a watched node that was seen alive stops answering. The first failure is
 * kept: later ones are its echoes.
 */
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace avsp
{
namespace results
{
/// Why a run stopped before its duration.
struct Abort
{
  std::string node;       ///< resolved node name, e.g. "/sensors"
  std::string reason;     ///< e.g. "exited with code 1; its last error: ..."
  double sim_time = 0.0;  ///< s, sim time when the failure was seen
};

/**
 * @brief The node a roslaunch process name stands for: "m113/controller-10" -> "/m113/controller"
 *        (roslaunch names a process after its node without the leading '/', plus "-<counter>").
 */
std::string nodeOfProcess(const std::string& process);

class RunWatch
{
public:
  /// @param watched resolved names of the nodes that must run until the run ends
  explicit RunWatch(std::vector<std::string> watched);

  /// A message of level ERROR or FATAL on /rosout from `node`; a FATAL from a watched node fails the run.
  void noteError(const std::string& node, const std::string& text, bool fatal, double sim_time);
  /// s (wall) a helper that exited with an unknown code leaves the clock to start.
  static constexpr double kStartGrace = 1.0;
  /**
   * @brief A process roslaunch reports dead, with its exit code if known (negative: killed by
   *        that signal; roslaunch does not tell a dead process's code over XML-RPC).
   * @param sim_time s, 0 while the run has not started
   * @param wall_time s, any epoch; for kStartGrace
   */
  void noteProcessDied(const std::string& process, std::optional<int> exit_code, double sim_time, double wall_time);
  /// The time now: fails the run for a helper that exited before a clock that did not start.
  void noteTime(double sim_time, double wall_time);
  /// Failed pings in a row after which a watched node counts as gone.
  static constexpr int kFailedPings = 2;
  /// A watched node answered (or did not answer) a ping; `why` says how it failed. A node
  /// fails the run after kFailedPings failures in a row, once it has answered once.
  void notePing(const std::string& node, bool answered, const std::string& why, double sim_time);

  /// The first failure, if any. For a node that died, the reason ends with the last error it
  /// logged as known now (its last /rosout lines may arrive after its death is seen).
  std::optional<Abort> abort() const;
  /// Fails the run for a reason outside the processes (e.g. run_recorder interrupted).
  void fail(const std::string& node, const std::string& reason, double sim_time);

  const std::vector<std::string>& watched() const { return watched_; }
  bool isWatched(const std::string& node) const { return watched_set_.count(node) > 0; }
  /// The last ERROR or FATAL text `node` logged, or "".
  std::string lastError(const std::string& node) const;

private:
  /// The first failure as seen; `with_last_error`: append the node's last error when read.
  struct Failure
  {
    Abort abort;
    bool with_last_error = false;
  };
  void failDied(const std::string& node, const std::string& what, double sim_time);

  std::vector<std::string> watched_;
  std::set<std::string> watched_set_;
  std::map<std::string, std::string> last_error_;
  std::set<std::string> seen_alive_;
  std::map<std::string, int> failed_pings_;
  std::map<std::string, double> exited_before_start_;  // helper -> wall time it was seen dead
  std::optional<Failure> failure_;
};

}  // namespace results
}  // namespace avsp
