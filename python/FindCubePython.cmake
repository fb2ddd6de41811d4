# Decides CUBE_COLLISION_PYTHON_DEFAULT: ON at top level when Python's headers, pybind11's CMake
# package and numpy are all there (Debian: python3-dev, pybind11-dev / python3-pybind11,
# python3-numpy), so that a plain build gets the Python package where it can be built and is
# not broken where it cannot. The interpreter: CUBE_COLLISION_PYTHON (or Python3_EXECUTABLE),
# default Debian's /usr/bin/python3; a pyenv python3 first on PATH does not see Debian's packages.
set(CUBE_COLLISION_PYTHON_DEFAULT OFF)
if(NOT Python3_EXECUTABLE)
  if(CUBE_COLLISION_PYTHON)
    set(Python3_EXECUTABLE "${CUBE_COLLISION_PYTHON}")
  elseif(EXISTS /usr/bin/python3)
    set(Python3_EXECUTABLE /usr/bin/python3)
  endif()
endif()
if(CUBE_COLLISION_TOP_LEVEL OR CUBE_COLLISION_BUILD_PYTHON)
  find_package(Python3 COMPONENTS Interpreter Development.Module QUIET)
  find_package(pybind11 CONFIG QUIET)
  if(Python3_FOUND AND pybind11_FOUND)
    execute_process(COMMAND "${Python3_EXECUTABLE}" -c "import numpy"
                    RESULT_VARIABLE _cube_numpy OUTPUT_QUIET ERROR_QUIET)
    # Not in sanitizer or fuzzer builds: an instrumented extension needs its runtime preloaded
    # into the interpreter.
    if(_cube_numpy EQUAL 0 AND CUBE_COLLISION_TOP_LEVEL AND NOT CUBE_COLLISION_SANITIZE
       AND NOT CUBE_COLLISION_BUILD_FUZZER)
      set(CUBE_COLLISION_PYTHON_DEFAULT ON)
    endif()
  endif()
  if(NOT CUBE_COLLISION_PYTHON_DEFAULT AND CUBE_COLLISION_TOP_LEVEL)
    message(STATUS "cube-collision: Python package off (needs python3-dev, pybind11-dev, python3-numpy)")
  endif()
endif()
