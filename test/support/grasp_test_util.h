// Grasp specs the grasp and simulation tests share.
#pragma once

#include <string>

#include "corde_sim/grasp/grasp.h"

namespace corde::test {

// A grasp of node `node` of the rod named "rod".
inline GraspSpec at_node(const std::string& name, int node) {
  GraspSpec s;
  s.name = name;
  s.rod = "rod";
  s.place = GraspSpec::Place::kNode;
  s.value = node;
  return s;
}

}  // namespace corde::test
