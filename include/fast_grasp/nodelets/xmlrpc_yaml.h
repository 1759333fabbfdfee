// Parameter-server values as YAML, so nodelets and offline tools share one parameter
// mapping (grasp_planner_params.h) and rosparam overrides still apply.
#pragma once

#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include <string>

namespace fast_grasp
{
inline YAML::Node toYaml(XmlRpc::XmlRpcValue& value)
{
  switch (value.getType())
  {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(value));
    case XmlRpc::XmlRpcValue::TypeInt:
      return YAML::Node(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return YAML::Node(static_cast<double>(value));
    case XmlRpc::XmlRpcValue::TypeString:
      return YAML::Node(static_cast<std::string>(value));
    case XmlRpc::XmlRpcValue::TypeArray:
    {
      YAML::Node list(YAML::NodeType::Sequence);
      for (int i = 0; i < value.size(); ++i)
        list.push_back(toYaml(value[i]));
      return list;
    }
    case XmlRpc::XmlRpcValue::TypeStruct:
    {
      YAML::Node map(YAML::NodeType::Map);
      for (auto& member : value)
        map[member.first] = toYaml(member.second);
      return map;
    }
    default:
      return YAML::Node();
  }
}

/// The parameter subtree `nh/name` as YAML; a null node when it is not set.
inline YAML::Node paramAsYaml(const ros::NodeHandle& nh, const std::string& name)
{
  XmlRpc::XmlRpcValue value;
  if (!nh.getParam(name, value))
    return YAML::Node();
  return toYaml(value);
}

}  // namespace fast_grasp
