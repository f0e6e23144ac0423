#pragma once
/**
 * @file input_diagnostics.hpp
 * @brief The summary of a node's `<node>: inputs` status on /diagnostics (terrain_node,
 *        sensors_node): a warning while messages are being ignored, OK otherwise.
 */
#include <cstdint>

#include <diagnostic_updater/DiagnosticStatusWrapper.h>

namespace avsp
{
namespace node
{
/**
 * @brief WARN "<n> message(s) ignored since the last report" when `ignored` (the node's running
 *        count) grew since `reported`, else OK; `reported` becomes `ignored`.
 */
inline void summarizeIgnoredInputs(diagnostic_updater::DiagnosticStatusWrapper& status, std::uint64_t ignored,
                                   std::uint64_t& reported)
{
  if (ignored > reported)
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%llu message(s) ignored since the last report",
                    static_cast<unsigned long long>(ignored - reported));
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "no input ignored since the last report");
  reported = ignored;
}

}  // namespace node
}  // namespace avsp
