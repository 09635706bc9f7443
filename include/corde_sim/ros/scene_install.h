// What corde_sim_node installs into its simulation driver: a scene (its world, its grasps with
// their sources and scripts), the robot's links as obstacles, and grasps made or let go at run
// time (~grasp, ~release). Loop thread only (start-up included).
#pragma once

#include <string>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/ros/node_params.h"
#include "corde_sim/ros/robot_obstacles.h"
#include "corde_sim/scene/scene.h"

namespace corde_sim {

class SimNode;

class SceneInstall {
 public:
  explicit SceneInstall(SimNode* node) : node_(*node) {}
  // `path` as a scene file: as given if it exists, else in the package or its scene folder; ""
  // and why not otherwise.
  std::string resolve_scene(const std::string& path, std::string* error) const;
  // Returns "" or why the scene cannot be used (then nothing changed).
  std::string install_scene(corde::Scene scene, const std::string& path);
  // The scene grasps with ~grasps/<name>/start_at_frame: each one's rod is moved rigidly so that
  // the held segment sits at its tf frame (times its offset), then settled in static equilibrium
  // hanging from it (corde::settle_rod; obstacles are not part of that solve). With `wait` the
  // frame is waited for up to the grasp's start_timeout (start-up: spins the global callback
  // queue, which fills the tf buffer); otherwise it must be in the buffer. "" or why not, naming
  // the parameter and frame (then the scene may be partly moved: the caller drops it).
  std::string place_at_frames(corde::Scene* scene, bool wait);
  std::string add_grasp(const corde::GraspSpec& spec, GraspSource source, const std::string& frame,
                        bool from_scene, int* segment);
  // Reads the URDF (throws std::invalid_argument naming the parameter, file and element); its
  // links join the world's obstacles after each new world (start-up, reset).
  void load_robot();
  void install_robot();
  // An input for grasp `name` arrived, or it was let go (`what`: "grasp '<name>' <what>"): its
  // keyframes stop moving it (logged once, at INFO); the state becomes the one to go back to.
  void end_script(const std::string& name, const char* what);
  // Whether grasp `name` is scripted, not held and its script will still take hold (before its
  // grasp_time, or unable to take hold yet): not one its script already let go.
  bool waiting_to_take_hold(const std::string& name) const;
  // A released grasp made through ~grasp (not the scene's), without a wrench: its topics and its
  // entry go. Returns whether it did.
  bool forget_grasp(const std::string& name);

  RobotObstacles& robot() { return robot_; }
  const RobotObstacles& robot() const { return robot_; }
  const corde::Scene& initial() const { return initial_; }
  const std::string& path() const { return scene_path_; }
  // restart_guard()'s note from the last install_scene, for ~reset's reply (then cleared).
  std::string take_guard_note() {
    std::string note;
    note.swap(guard_note_);
    return note;
  }

 private:
  SimNode& node_;
  std::string scene_path_;
  corde::Scene initial_;  // the scene as loaded, for ~reset
  RobotObstacles robot_;  // robot links as obstacles, and what was warned about them
  int next_marker_id_ = 0;
  bool installed_ = false;  // a scene was installed (start-up is over: frames are not waited for)
  std::string guard_note_;
};

}  // namespace corde_sim
