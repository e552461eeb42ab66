# PyPI's ROS 2 wheels were built in manylinux, and their exported rosidl_generator_py targets name that image's
# Python and NumPy headers (/opt/python/cpXY-cpXY/...): point them at this interpreter's instead.
find_package(Python3 REQUIRED COMPONENTS Interpreter Development)
execute_process(COMMAND ${Python3_EXECUTABLE} -c "import numpy; print(numpy.get_include())"
  OUTPUT_VARIABLE numpy_include OUTPUT_STRIP_TRAILING_WHITESPACE COMMAND_ERROR_IS_FATAL ANY)
foreach(dep builtin_interfaces std_msgs geometry_msgs trajectory_msgs action_msgs unique_identifier_msgs service_msgs)
  find_package(${dep} REQUIRED)  # before rosidl_generate_interfaces finds it, for srv/action
  set(target ${dep}::${dep}__rosidl_generator_py)
  if(TARGET ${target})
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    list(TRANSFORM dirs REPLACE "^/opt/python/cp[0-9]+-cp[0-9]+/include/python[0-9.]+$" "${Python3_INCLUDE_DIRS}")
    list(TRANSFORM dirs REPLACE "^/opt/python/cp[0-9]+-cp[0-9]+/.*/numpy/(_core/)?include$" "${numpy_include}")
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${dirs}")
  endif()
endforeach()
