// Checks of a URDF's text before and after urdfdom reads it. urdfdom skips a collision element
// whose geometry or origin does not parse (and keeps the model), its XML parser recurses once per
// nesting level, and it bounds nothing: the text is read here as well, with tinyxml2 (whose
// nesting depth is bounded), so that such files are refused naming the link and the element.
#pragma once

#include <map>
#include <string>

namespace corde {

// Collision elements of every link as the XML has them, by link name.
struct UrdfXmlSummary {
  std::map<std::string, int> collisions;
  int links = 0;
};

// Checks the URDF text `xml` (messages start with `doc`): its size (SceneLimits::max_urdf_bytes),
// that it is XML with a <robot> root, nested at most 100 levels deep, with at most
// SceneLimits::max_urdf_links links, and every collision element: an origin of finite numbers
// within SceneLimits::max_length, one known geometry (box, cylinder, sphere, mesh) with positive
// finite sizes within max_length, a mesh with a file name and a finite non-zero scale. Throws
// std::runtime_error naming the link and the collision element (index from 0) and the value.
UrdfXmlSummary check_urdf_xml(const std::string& xml, const std::string& doc);

// `value` for a message: quoted, cut to its first 100 characters (with its length) when longer.
std::string quote_value(const std::string& value);

}  // namespace corde
