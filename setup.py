# The Python package corde_sim (python/corde_sim) for catkin_python_setup(): relayed into the
# devel space and installed by `make install` / `catkin_make install` (docs/python.md). Not for
# pip: its extension corde_sim._core is built by CMake (cmake/CordePython.cmake).
from setuptools import setup

from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["corde_sim"], package_dir={"": "python"}))
