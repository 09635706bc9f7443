// corde_sim._core: the Python bindings of the rod library (pybind11). The Python package
// corde_sim (python/corde_sim) wraps them: overrides from a dict, rods by name, docstrings
// (docs/python.md). States come out as numpy arrays, copies of the library's.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <string>
#include <vector>

#include "corde_sim/integrators/integrator_names.h"
#include "scene_simulation.h"

namespace py = pybind11;
using corde::python::SceneSimulation;

namespace {

py::array_t<double> vec3_rows(const std::vector<corde::Vec3>& v) {
  py::array_t<double> out({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  auto a = out.mutable_unchecked<2>();
  for (size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) a(i, k) = v[i][k];
  return out;
}

py::array_t<double> vec3(const corde::Vec3& v) {
  py::array_t<double> out(3);
  for (int k = 0; k < 3; ++k) out.mutable_at(k) = v[k];
  return out;
}

// Quaternions as rows w, x, y, z.
py::array_t<double> quat_rows(const std::vector<corde::Quat>& q) {
  py::array_t<double> out({static_cast<py::ssize_t>(q.size()), py::ssize_t{4}});
  auto a = out.mutable_unchecked<2>();
  for (size_t i = 0; i < q.size(); ++i) {
    a(i, 0) = q[i].w();
    a(i, 1) = q[i].x();
    a(i, 2) = q[i].y();
    a(i, 3) = q[i].z();
  }
  return out;
}

const corde::Rod& rod_of(const SceneSimulation& s, const py::object& rod) {
  if (py::isinstance<py::str>(rod)) return s.rod(s.rod_index(rod.cast<std::string>()));
  return s.rod(rod.cast<int>());
}

int rod_index_of(const SceneSimulation& s, const py::object& rod) {
  if (py::isinstance<py::str>(rod)) return s.rod_index(rod.cast<std::string>());
  const int index = rod.cast<int>();
  s.rod(index);  // throws for one out of range
  return index;
}

py::dict guard_event_dict(const corde::GuardEvent& e) {
  static const char* actions[] = {"none", "halve_step", "implicit", "give_up", "restore"};
  py::dict d;
  d["time"] = e.time;
  d["kind"] = corde::guard_event_kind_name(e.kind);
  d["action"] = actions[static_cast<int>(e.action)];
  d["rollback_to"] = e.rollback_to;
  d["rod"] = e.rod;
  d["item"] = e.item;
  d["detail"] = e.detail;
  d["time_step"] = e.time_step;
  d["integrator"] = corde::integrator_name(e.integrator);
  d["message"] = e.message();
  return d;
}

py::dict event_dict(const corde::SimulationEvent& e) {
  static const char* kinds[] = {"guard",       "took_hold",    "let_go",
                                "cannot_hold", "script_ended", "stalled"};
  py::dict d;
  d["time"] = e.time;
  d["kind"] = kinds[static_cast<int>(e.kind)];
  d["grasp"] = e.grasp;
  d["text"] = e.kind == corde::SimulationEvent::Kind::kGuard ? e.guard.message() : e.text;
  return d;
}

py::dict equilibrium_dict(const corde::SceneEquilibrium& eq, const std::string& summary) {
  py::dict d;
  d["ok"] = eq.ok;
  d["problem"] = eq.problem;
  d["time"] = eq.time;
  d["wall_seconds"] = eq.wall_seconds;
  d["summary"] = summary;
  py::list rods;
  for (const corde::RodEquilibrium& r : eq.rods) {
    py::dict e;
    e["rod"] = r.rod;
    e["converged"] = r.result.converged;
    e["iterations"] = r.result.iterations;
    e["load_steps"] = r.result.load_steps;
    e["attempts"] = r.attempts;
    e["residual"] = r.result.residual;
    e["relative_residual"] = r.result.relative_residual;
    e["reference_force"] = r.result.reference_force;
    e["energy"] = r.result.energy;
    e["negative_modes"] = r.negative_modes;
    e["zero_modes"] = r.zero_modes;
    e["potential"] = r.potential;
    e["lowest_node"] = r.lowest_node;
    e["lowest_z"] = r.lowest_z;
    e["support_z"] = r.support_z;
    e["sag"] = r.sag;
    rods.append(e);
  }
  d["rods"] = rods;
  return d;
}

// The guard: on or off, and the settings a dict names (GuardSettings' fields).
corde::RunOptions run_options(bool guard, const py::dict& settings) {
  corde::RunOptions options;
  corde::GuardSettings& g = options.guard;
  g.enabled = guard;
  for (const auto& kv : settings) {
    const std::string key = py::str(kv.first);
    const py::handle v = kv.second;
    if (key == "check_every")
      g.check_every = v.cast<int>();
    else if (key == "max_halvings")
      g.max_halvings = v.cast<int>();
    else if (key == "allow_implicit")
      g.allow_implicit = v.cast<bool>();
    else if (key == "energy_tolerance")
      g.energy_tolerance = v.cast<double>();
    else if (key == "energy_floor")
      g.energy_floor = v.cast<double>();
    else if (key == "relax_after")
      g.relax_after = v.cast<double>();
    else
      throw std::invalid_argument("guard: unknown setting '" + key +
                                  "' (known: check_every, max_halvings, allow_implicit, "
                                  "energy_tolerance, energy_floor, relax_after)");
  }
  if (g.check_every < 1 || g.max_halvings < 0)
    throw std::invalid_argument("guard: check_every must be >= 1 and max_halvings >= 0");
  return options;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "corde_sim's rod library (use the corde_sim package, docs/python.md)";

  // Exceptions: one base, and each also a builtin kind (a bad scene is a ValueError).
  static py::object error = py::reinterpret_steal<py::object>(
      PyErr_NewException("corde_sim.Error", PyExc_RuntimeError, nullptr));
  auto make = [&](const char* name, PyObject* builtin) {
    py::tuple bases = py::make_tuple(error, py::handle(builtin));
    return py::reinterpret_steal<py::object>(PyErr_NewException(name, bases.ptr(), nullptr));
  };
  static py::object scene_error = make("corde_sim.SceneError", PyExc_ValueError);
  static py::object guard_error = make("corde_sim.GuardError", PyExc_RuntimeError);
  static py::object runaway_error = make("corde_sim.RunawayError", PyExc_RuntimeError);
  static py::object statics_error = make("corde_sim.StaticsError", PyExc_RuntimeError);
  m.attr("Error") = error;
  m.attr("SceneError") = scene_error;
  m.attr("GuardError") = guard_error;
  m.attr("RunawayError") = runaway_error;
  m.attr("StaticsError") = statics_error;
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const corde::SceneError& e) {
      PyErr_SetString(scene_error.ptr(), e.what());
    } catch (const corde::python::GuardFailure& e) {
      PyErr_SetString(guard_error.ptr(), e.what());
    } catch (const corde::python::RunawayFailure& e) {
      PyErr_SetString(runaway_error.ptr(), e.what());
    } catch (const corde::python::StaticsFailure& e) {
      PyErr_SetString(statics_error.ptr(), e.what());
    }
  });

  py::class_<SceneSimulation>(m, "_Simulation")
      .def_static(
          "load",
          [](const std::string& path, const std::vector<std::string>& overrides, bool guard,
             const py::dict& settings) {
            return SceneSimulation::load(path, overrides, run_options(guard, settings));
          },
          py::arg("path"), py::arg("overrides"), py::arg("guard"), py::arg("settings"))
      .def_static(
          "parse",
          [](const std::string& yaml, const std::vector<std::string>& overrides,
             const std::string& source, bool guard, const py::dict& settings) {
            return SceneSimulation::parse(yaml, overrides, source, run_options(guard, settings));
          },
          py::arg("yaml"), py::arg("overrides"), py::arg("source"), py::arg("guard"),
          py::arg("settings"))
      .def("step", &SceneSimulation::step, py::arg("n"), py::call_guard<py::gil_scoped_release>())
      .def("run", &SceneSimulation::run, py::arg("duration"),
           py::call_guard<py::gil_scoped_release>())
      .def("problem", &SceneSimulation::problem)
      .def(
          "statics",
          [](SceneSimulation& s, double t, bool check) {
            corde::SceneEquilibrium eq;
            {
              py::gil_scoped_release release;
              eq = s.statics(t);
            }
            if (check && !eq.ok) throw corde::python::StaticsFailure("statics: " + eq.problem);
            return equilibrium_dict(eq, s.statics_summary(eq));
          },
          py::arg("time"), py::arg("check"))
      .def(
          "statics_sensitivity",
          [](SceneSimulation& s, const py::object& rod, const std::vector<std::string>& params) {
            std::vector<corde::StaticSensitivity> d;
            const int index = rod_index_of(s, rod);
            {
              py::gil_scoped_release release;
              d = s.statics_sensitivity(index, params);
            }
            py::dict positions, rotations;
            for (size_t j = 0; j < params.size(); ++j) {
              positions[py::str(params[j])] = vec3_rows(d[j].positions);
              rotations[py::str(params[j])] = vec3_rows(d[j].rotations);
            }
            return py::make_tuple(positions, rotations);
          },
          py::arg("rod"), py::arg("parameters"))
      .def_property_readonly("time", [](const SceneSimulation& s) { return s.world().time(); })
      .def_property_readonly("time_step",
                             [](const SceneSimulation& s) { return s.world().time_step; })
      .def_property_readonly("steps", &SceneSimulation::steps)
      .def_property_readonly("duration",
                             [](const SceneSimulation& s) { return s.scene().duration; })
      .def_property_readonly("statics_time",
                             [](const SceneSimulation& s) { return s.scene().statics_time; })
      .def_property_readonly(
          "statics_mode",
          [](const SceneSimulation& s) { return s.scene().mode == corde::Scene::Mode::kStatics; })
      .def_property_readonly("integrator",
                             [](const SceneSimulation& s) {
                               return std::string(corde::integrator_name(s.world().integrator));
                             })
      .def_property_readonly("gravity",
                             [](const SceneSimulation& s) { return vec3(s.world().gravity); })
      .def_property_readonly("name", [](const SceneSimulation& s) { return s.scene().name; })
      .def_property_readonly("source", [](const SceneSimulation& s) { return s.scene().source; })
      .def_property_readonly("warnings",
                             [](const SceneSimulation& s) { return s.scene().warnings; })
      .def_property_readonly("notes", [](const SceneSimulation& s) { return s.scene().notes; })
      .def_property_readonly("settled", [](const SceneSimulation& s) { return s.scene().settled; })
      .def_property_readonly("rod_names",
                             [](const SceneSimulation& s) {
                               std::vector<std::string> names;
                               for (const corde::Rod& r : s.world().rods())
                                 names.push_back(r.name());
                               return names;
                             })
      .def("rod_index", &SceneSimulation::rod_index, py::arg("name"))
      .def(
          "positions",
          [](const SceneSimulation& s, const py::object& rod) {
            return vec3_rows(rod_of(s, rod).positions());
          },
          py::arg("rod"))
      .def(
          "velocities",
          [](const SceneSimulation& s, const py::object& rod) {
            return vec3_rows(rod_of(s, rod).velocities());
          },
          py::arg("rod"))
      .def(
          "frames",
          [](const SceneSimulation& s, const py::object& rod) {
            return quat_rows(rod_of(s, rod).orientations());
          },
          py::arg("rod"))
      .def(
          "angular_velocities",
          [](const SceneSimulation& s, const py::object& rod) {
            return vec3_rows(rod_of(s, rod).angular_velocities());
          },
          py::arg("rod"))
      .def(
          "rest_lengths",
          [](const SceneSimulation& s, const py::object& rod) {
            const std::vector<double>& l = rod_of(s, rod).rest_lengths();
            return py::array_t<double>(static_cast<py::ssize_t>(l.size()), l.data());
          },
          py::arg("rod"))
      .def(
          "energies",
          [](const SceneSimulation& s, const py::object& rod) {
            const corde::Energies e = rod_of(s, rod).energies(s.world().gravity);
            py::dict d;
            d["kinetic_translation"] = e.kinetic_translation;
            d["kinetic_rotation"] = e.kinetic_rotation;
            d["stretch"] = e.stretch;
            d["bend_twist"] = e.bend_twist;
            d["coupling"] = e.coupling;
            d["gravity"] = e.gravity;
            d["total"] = e.kinetic() + e.elastic() + e.gravity;
            return d;
          },
          py::arg("rod"))
      .def("reactions",
           [](const SceneSimulation& s) {
             py::list out;
             for (const corde::Support& support : s.scene().supports) {
               const corde::Wrench w = corde::support_reaction(s.world().rod(support.rod), support);
               py::dict d;
               d["support"] = support.name;
               d["rod"] = support.rod;
               d["force"] = vec3(w.force);
               d["moment"] = vec3(w.moment);
               d["point"] = vec3(w.point);
               out.append(d);
             }
             return out;
           })
      .def("guard_events",
           [](const SceneSimulation& s) {
             py::list out;
             for (const corde::GuardEvent& e : s.guard_events()) out.append(guard_event_dict(e));
             return out;
           })
      .def("events", [](const SceneSimulation& s) {
        py::list out;
        for (const corde::SimulationEvent& e : s.events()) out.append(event_dict(e));
        return out;
      });
}
