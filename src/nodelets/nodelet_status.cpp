#include "fast_grasp/nodelets/nodelet_status.h"

#include <std_msgs/String.h>

namespace fast_grasp
{
void NodeletStatus::init(ros::NodeHandle& nh, ros::NodeHandle& private_nh, const std::string& name)
{
  name_ = name;
  status_pub_ = private_nh.advertise<std_msgs::String>("status", 10, /*latch=*/true);
  updater_ = std::make_unique<diagnostic_updater::Updater>(nh, private_nh, name);
  updater_->setHardwareID("none");
  updater_->add(name, this, &NodeletStatus::fillDiagnostics);
  diagnostics_timer_ = nh.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { updater_->update(); });
}

NodeletStatus::~NodeletStatus()
{
  // Shutting a ros::Timer down waits for a callback of it that is running (CallbackQueue::removeByID).
  diagnostics_timer_.stop();
}

void NodeletStatus::report(Level level, const std::string& message)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    level_ = level;
    message_ = message;
    ++processed_;
    if (level == Level::Error)
      ++errors_;
  }
  static const char* const prefixes[] = { "OK: ", "WARN: ", "ERROR: " };
  std_msgs::String text;
  text.data = prefixes[static_cast<int>(level)] + message;
  status_pub_.publish(text);
  if (level != Level::Ok)
    updater_->force_update();
}

void NodeletStatus::fillDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  std::lock_guard<std::mutex> lock(mutex_);
  using diagnostic_msgs::DiagnosticStatus;
  const unsigned char levels[] = { DiagnosticStatus::OK, DiagnosticStatus::WARN, DiagnosticStatus::ERROR };
  status.summary(levels[static_cast<int>(level_)], message_);
  status.add("messages processed", processed_);
  status.add("errors", errors_);
}

}  // namespace fast_grasp
