# Install rules: headers, the library, the CMake package CubeCollision (target
# CubeCollision::cube_collision) and the pkg-config file cube_collision.pc.
# Included at the end of the top-level CMakeLists.txt, once every link of cube_collision is known.

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(CUBE_COLLISION_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/CubeCollision)

install(TARGETS cube_collision EXPORT CubeCollisionTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
# Public headers only: include/cube_collision/detail/ is the library's own and is not installed.
# (This needs public headers that do not include detail/ headers.)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/cube_collision
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  FILES_MATCHING PATTERN "*.h"
  PATTERN "detail" EXCLUDE)
install(EXPORT CubeCollisionTargets
  NAMESPACE CubeCollision::
  DESTINATION ${CUBE_COLLISION_CMAKE_DIR})

# A static library carries its private links into the consumer's link: if the library links
# Cairo (the optional SVG/PNG export), consumers of a static install must find Cairo too. A
# shared library hides it.
get_target_property(_cube_type cube_collision TYPE)
get_target_property(_cube_links cube_collision LINK_LIBRARIES)
set(CUBE_COLLISION_NEEDS_CAIRO OFF)
if(_cube_type STREQUAL "STATIC_LIBRARY" AND "PkgConfig::CAIRO" IN_LIST _cube_links)
  set(CUBE_COLLISION_NEEDS_CAIRO ON)
endif()
# The same for the OpenMP runtime of the narrow phase's threads.
set(CUBE_COLLISION_NEEDS_OPENMP OFF)
if(_cube_type STREQUAL "STATIC_LIBRARY" AND "OpenMP::OpenMP_CXX" IN_LIST _cube_links)
  set(CUBE_COLLISION_NEEDS_OPENMP ON)
endif()

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/CubeCollisionConfig.cmake.in
  ${PROJECT_BINARY_DIR}/CubeCollisionConfig.cmake
  INSTALL_DESTINATION ${CUBE_COLLISION_CMAKE_DIR})
# 0.x releases follow the same rule: any 0.y satisfies find_package(CubeCollision 0.x).
write_basic_package_version_file(${PROJECT_BINARY_DIR}/CubeCollisionConfigVersion.cmake
  VERSION ${PROJECT_VERSION}
  COMPATIBILITY SameMajorVersion)
install(FILES
  ${PROJECT_BINARY_DIR}/CubeCollisionConfig.cmake
  ${PROJECT_BINARY_DIR}/CubeCollisionConfigVersion.cmake
  DESTINATION ${CUBE_COLLISION_CMAKE_DIR})

# pkg-config: the prefix is found relative to the .pc file, so `cmake --install --prefix P`
# (which overrides the configured prefix) gives a correct file.
set(_cube_pc_dir ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
if(IS_ABSOLUTE "${_cube_pc_dir}")
  set(CUBE_COLLISION_PC_PREFIX "${CMAKE_INSTALL_PREFIX}")
else()
  file(RELATIVE_PATH _cube_up "/root/${_cube_pc_dir}" "/root")
  string(REGEX REPLACE "/$" "" _cube_up "${_cube_up}")
  set(CUBE_COLLISION_PC_PREFIX "\${pcfiledir}/${_cube_up}")
endif()
# The file names no other package in Requires: pkg-config would then add that package's Cflags,
# and Debian's fcl.pc says -std=c++11, which comes after the user's -std=c++17 in
# `c++ -std=c++17 main.cpp $(pkg-config --cflags --libs cube_collision)` and wins. Instead, FCL's
# flags (and those of what it needs: Eigen's include directory; ccd and octomap to link) are
# written into our Cflags/Libs here, less any -std=.
include(${PROJECT_SOURCE_DIR}/cmake/CubePkgConfigFlags.cmake)
cube_pc_flags_of_fcl(_cube_fcl_cflags _cube_fcl_libs)
set(CUBE_COLLISION_PC_CFLAGS "")
if(_cube_fcl_cflags)
  set(CUBE_COLLISION_PC_CFLAGS " ${_cube_fcl_cflags}")
endif()
set(CUBE_COLLISION_PC_LIBS "${_cube_fcl_libs}")
if(CUBE_COLLISION_HAS_CAIRO)
  # Public compile definition of the target: the headers declare the image export under it.
  string(APPEND CUBE_COLLISION_PC_CFLAGS " -DCUBE_COLLISION_HAS_CAIRO")
endif()
if(CUBE_COLLISION_NEEDS_CAIRO)
  # A static library linked with Cairo: every consumer's link needs Cairo (-lcairo), with or
  # without --static.
  cube_pc_flags_of_module(cairo _cube_cairo_cflags _cube_cairo_libs _cube_cairo_static_libs)
  if(NOT CUBE_PC_MODULE_FOUND)
    set(_cube_cairo_libs "-lcairo")
  endif()
  set(CUBE_COLLISION_PC_LIBS "${_cube_cairo_libs} ${CUBE_COLLISION_PC_LIBS}")
endif()
if(CUBE_COLLISION_NEEDS_OPENMP)
  # The compiler's OpenMP runtime, as the compiler's own flag links it (GCC: libgomp).
  set(CUBE_COLLISION_PC_LIBS "${CUBE_COLLISION_PC_LIBS} ${OpenMP_CXX_FLAGS}")
endif()
string(STRIP "${CUBE_COLLISION_PC_LIBS}" CUBE_COLLISION_PC_LIBS)
configure_file(${PROJECT_SOURCE_DIR}/cmake/cube_collision.pc.in
  ${PROJECT_BINARY_DIR}/cube_collision.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/cube_collision.pc DESTINATION ${_cube_pc_dir})
