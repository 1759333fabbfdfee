// ~status topic plus /diagnostics for every fast_grasp nodelet.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <memory>
#include <mutex>
#include <string>

namespace fast_grasp
{
/// Publishes one line per processed message on ~status ("OK: ...", "WARN: ...",
/// "ERROR: ...", latched) and the same level and text, with counters, on /diagnostics.
class NodeletStatus
{
public:
  enum class Level
  {
    Ok,
    Warn,
    Error
  };

  NodeletStatus() = default;
  NodeletStatus(const NodeletStatus&) = delete;
  NodeletStatus& operator=(const NodeletStatus&) = delete;
  /// Stops the diagnostics timer first: its callback reads the members below, which the
  /// implicit destructor would destroy while a manager worker thread may still run it.
  ~NodeletStatus();

  /// `name` is the diagnostic task name (the nodelet's name).
  void init(ros::NodeHandle& nh, ros::NodeHandle& private_nh, const std::string& name);

  void ok(const std::string& message) { report(Level::Ok, message); }
  void warn(const std::string& message) { report(Level::Warn, message); }
  void error(const std::string& message) { report(Level::Error, message); }
  void report(Level level, const std::string& message);

private:
  void fillDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::Publisher status_pub_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  ros::Timer diagnostics_timer_;
  std::mutex mutex_;
  Level level_ = Level::Ok;
  std::string message_ = "waiting for input";
  std::string name_;
  unsigned long processed_ = 0;
  unsigned long errors_ = 0;
};

}  // namespace fast_grasp
