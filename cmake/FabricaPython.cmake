# The `fabrica` Python module (python/, issue 16): pybind11 and Python from
# Debian. The interpreter defaults to /usr/bin/python3 (Debian's numpy and
# pybind11 live there; a pyenv python3 may come first on PATH); set
# Python3_EXECUTABLE to use another. FABRICA_WITH_PYTHON defaults to ON when
# both are found.
if(NOT DEFINED Python3_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python3_EXECUTABLE /usr/bin/python3 CACHE FILEPATH "Python interpreter for the fabrica module")
endif()
find_package(Python3 COMPONENTS Interpreter Development.Module QUIET)
if(Python3_FOUND)
  find_package(pybind11 2.6 CONFIG QUIET)
endif()
set(_fabrica_python_numpy FALSE)
if(Python3_FOUND)
  # The module hands out numpy arrays: the interpreter must have numpy.
  execute_process(COMMAND ${Python3_EXECUTABLE} -c "import numpy"
                  RESULT_VARIABLE _fabrica_numpy_rc OUTPUT_QUIET ERROR_QUIET)
  if(_fabrica_numpy_rc EQUAL 0)
    set(_fabrica_python_numpy TRUE)
  endif()
endif()
set(_fabrica_python_default OFF)
if(Python3_FOUND AND pybind11_FOUND AND _fabrica_python_numpy AND TARGET fabrica_lines)
  set(_fabrica_python_default ON)
endif()
option(FABRICA_WITH_PYTHON "Build the fabrica Python module (pybind11)" ${_fabrica_python_default})
if(FABRICA_WITH_PYTHON)
  if(NOT Python3_FOUND OR NOT pybind11_FOUND)
    message(FATAL_ERROR "FABRICA_WITH_PYTHON needs Python 3 (development files) and pybind11: "
                        "apt-get install python3-dev pybind11-dev python3-numpy, or "
                        "-DFABRICA_WITH_PYTHON=OFF")
  endif()
  add_subdirectory(python)
elseif(NOT _fabrica_python_default)
  message(STATUS "fabrica: Python module off (needs python3-dev, pybind11-dev and python3-numpy "
                 "for ${Python3_EXECUTABLE})")
endif()
