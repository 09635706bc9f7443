// Checks of a URDF's text with tinyxml2 (see urdf_checks.h for why urdfdom's reading is not
// enough).
#include "urdf_checks.h"

#include <tinyxml2.h>

#include <array>
#include <cmath>
#include <locale>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "corde_sim/scene/scene.h"

namespace corde {

namespace {

using tinyxml2::XMLElement;

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The three numbers of attribute `attr` ("x y z"), as urdfdom reads them (C locale, separated by
// white space); `fail` gets why not.
template <class Fail>
std::array<double, 3> three_numbers(const XMLElement& e, const char* attr, const Fail& fail) {
  const char* text = e.Attribute(attr);
  std::array<double, 3> v{0.0, 0.0, 0.0};
  if (!text) return v;
  const std::string what = std::string(e.Name()) + " " + attr + "=" + quote_value(text);
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  std::string token;
  int n = 0;
  while (in >> token) {
    if (n == 3) fail(what + ": expected 3 numbers separated by spaces, got more");
    std::istringstream num(token);
    num.imbue(std::locale::classic());
    double x = 0.0;
    if (!(num >> x) || num.peek() != std::char_traits<char>::eof())
      fail(what + ": '" + token.substr(0, 100) +
           "' is not a number (expected 3 numbers separated by spaces)");
    if (!std::isfinite(x)) fail(what + ": " + token.substr(0, 100) + " is not finite");
    v[n++] = x;
  }
  if (n != 3) fail(what + ": expected 3 numbers separated by spaces, got " + std::to_string(n));
  return v;
}

// A positive finite number of at most max_length (m) in attribute `attr`.
template <class Fail>
double length(const XMLElement& e, const char* attr, const Fail& fail) {
  const std::string what = std::string(e.Name()) + " " + attr;
  const char* text = e.Attribute(attr);
  if (!text) fail(what + " is missing");
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  double x = 0.0;
  if (!(in >> x) || !(in >> std::ws).eof()) fail(what + "=" + quote_value(text) + ": not a number");
  if (!std::isfinite(x) || x <= 0.0 || x > SceneLimits::max_length)
    fail(what + "=" + quote_value(text) + ": must be positive, at most " +
         number_text(SceneLimits::max_length) + " m");
  return x;
}

void check_collision(const XMLElement& col, const std::string& where) {
  auto fail = [&](const std::string& why) { throw std::runtime_error(where + ": " + why); };
  if (const XMLElement* origin = col.FirstChildElement("origin")) {
    const std::array<double, 3> xyz = three_numbers(*origin, "xyz", fail);
    three_numbers(*origin, "rpy", fail);
    for (double x : xyz)
      if (std::abs(x) > SceneLimits::max_length)
        fail("origin xyz=" + quote_value(origin->Attribute("xyz")) + ": beyond " +
             number_text(SceneLimits::max_length) + " m");
  }
  const XMLElement* geometry = col.FirstChildElement("geometry");
  if (!geometry) fail("no <geometry>");
  const XMLElement* shape = geometry->FirstChildElement();
  if (!shape) fail("empty <geometry> (expected box, cylinder, sphere or mesh)");
  const std::string kind = shape->Name();
  if (kind == "box") {
    if (!shape->Attribute("size")) fail("box size is missing");
    const std::array<double, 3> size = three_numbers(*shape, "size", fail);
    for (double x : size)
      if (x <= 0.0 || x > SceneLimits::max_length)
        fail("box size=" + quote_value(shape->Attribute("size")) + ": must be positive, at most " +
             number_text(SceneLimits::max_length) + " m");
  } else if (kind == "sphere") {
    length(*shape, "radius", fail);
  } else if (kind == "cylinder") {
    length(*shape, "radius", fail);
    length(*shape, "length", fail);
  } else if (kind == "mesh") {
    const char* file = shape->Attribute("filename");
    if (!file || !*file) fail("mesh filename is missing");
    if (shape->Attribute("scale")) {
      for (double s : three_numbers(*shape, "scale", fail))
        if (s == 0.0)
          fail("mesh scale=" + quote_value(shape->Attribute("scale")) + ": must not be 0");
    }
  } else {
    fail("unknown geometry <" + kind.substr(0, 100) + "> (expected box, cylinder, sphere or mesh)");
  }
}

// The joints must make the links a tree: urdfdom accepts a link that is the child of two joints
// (walked once per parent, a lattice of such links exponentially often) and cycles of joints
// (whose links it then leaks, holding each other).
void check_tree(const XMLElement& robot, const std::string& doc) {
  // (Checked here rather than left to urdfdom, which would fail half-way through linking a
  // long chain and then destroy it recursively.)
  std::set<std::string> links;
  for (const XMLElement* link = robot.FirstChildElement("link"); link;
       link = link->NextSiblingElement("link"))
    if (link->Attribute("name")) links.insert(link->Attribute("name"));
  std::map<std::string, std::string> parent_joint, parent_link;  // by child link
  for (const XMLElement* joint = robot.FirstChildElement("joint"); joint;
       joint = joint->NextSiblingElement("joint")) {
    const XMLElement* parent = joint->FirstChildElement("parent");
    const XMLElement* child = joint->FirstChildElement("child");
    const char* name = joint->Attribute("name");
    if (!name || !parent || !child || !parent->Attribute("link") || !child->Attribute("link"))
      continue;  // urdfdom refuses it with its own message
    const std::string c = child->Attribute("link");
    for (const std::string& l : {std::string(parent->Attribute("link")), c})
      if (!links.count(l))
        throw std::runtime_error(doc + ": joint " + quote_value(name) + ": link " + quote_value(l) +
                                 " is not a link of the robot");
    const auto [it, fresh] = parent_joint.emplace(c, name);
    if (!fresh)
      throw std::runtime_error(doc + ": link " + quote_value(c) + " is the child of two joints, " +
                               quote_value(it->second) + " and " + quote_value(name) +
                               " (the links must form a tree)");
    parent_link[c] = parent->Attribute("link");
  }
  // Up from every link to a link without a parent; meeting the path walked so far is a cycle.
  std::map<std::string, int> state;  // 1: on the current path, 2: leads to a root
  for (const auto& start : parent_link) {
    std::string at = start.first;
    std::vector<std::string> walked;
    while (state[at] == 0) {
      state[at] = 1;
      walked.push_back(at);
      const auto up = parent_link.find(at);
      if (up == parent_link.end()) break;
      at = up->second;
    }
    if (state[at] == 1 && parent_link.count(at))
      throw std::runtime_error(doc + ": link " + quote_value(at) +
                               " lies on a cycle of joints (the links must form a tree)");
    for (const std::string& l : walked) state[l] = 2;
  }
  std::string root;
  for (const std::string& l : links) {
    if (parent_link.count(l)) continue;
    if (!root.empty())
      throw std::runtime_error(doc + ": two root links (links that are no joint's child), " +
                               quote_value(root) + " and " + quote_value(l) +
                               " (the links must form one tree)");
    root = l;
  }
}

}  // namespace

std::string quote_value(const std::string& value) {
  if (value.size() <= 100) return "'" + value + "'";
  return "'" + value.substr(0, 100) + "...' (" + std::to_string(value.size()) + " characters)";
}

UrdfXmlSummary check_urdf_xml(const std::string& xml, const std::string& doc) {
  if (xml.size() > static_cast<size_t>(SceneLimits::max_urdf_bytes))
    throw std::runtime_error(doc + ": larger than the limit of " +
                             std::to_string(SceneLimits::max_urdf_bytes) + " bytes for a URDF (" +
                             std::to_string(xml.size()) + " bytes)");
  tinyxml2::XMLDocument dom;
  dom.Parse(xml.data(), xml.size());
  const std::string no_robot = doc + ": not a URDF (no <robot> element)";
  // Text with no <robot in it at all (another file, a binary) is no URDF, whatever XML says.
  if (dom.ErrorID() == tinyxml2::XML_ERROR_EMPTY_DOCUMENT ||
      (dom.Error() && xml.find("<robot") == std::string::npos))
    throw std::runtime_error(no_robot);
  if (dom.ErrorID() == tinyxml2::XML_ELEMENT_DEPTH_EXCEEDED)
    throw std::runtime_error(doc + ": XML elements nested deeper than " +
                             std::to_string(TINYXML2_MAX_ELEMENT_DEPTH) +
                             " levels (a URDF needs about 5)");
  if (dom.Error())
    throw std::runtime_error(doc + ": not a valid URDF (not well-formed XML: " +
                             std::string(dom.ErrorStr()).substr(0, 200) + ")");
  const XMLElement* robot = dom.FirstChildElement("robot");
  if (!robot) throw std::runtime_error(no_robot);
  UrdfXmlSummary out;
  for (const XMLElement* link = robot->FirstChildElement("link"); link;
       link = link->NextSiblingElement("link"))
    ++out.links;
  if (out.links > SceneLimits::max_urdf_links)
    throw std::runtime_error(doc + ": has " + std::to_string(out.links) +
                             " links, more than the limit of " +
                             std::to_string(SceneLimits::max_urdf_links));
  check_tree(*robot, doc);
  for (const XMLElement* link = robot->FirstChildElement("link"); link;
       link = link->NextSiblingElement("link")) {
    const char* name = link->Attribute("name");
    if (!name) continue;  // urdfdom refuses it with its own message
    int i = 0;
    for (const XMLElement* col = link->FirstChildElement("collision"); col;
         col = col->NextSiblingElement("collision"), ++i)
      check_collision(*col,
                      doc + ": link " + quote_value(name) + " collision " + std::to_string(i));
    out.collisions[name] = i;
  }
  return out;
}

}  // namespace corde
