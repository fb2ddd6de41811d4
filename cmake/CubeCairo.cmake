# Finds Cairo for the SVG/PNG export of the hierarchy (Debian: libcairo2-dev). Optional: without
# it the library is built without writeSvg/writePng and CUBE_COLLISION_HAS_CAIRO stays undefined.
# Sets CUBE_COLLISION_HAS_CAIRO (ON/OFF) and, when ON, the imported target PkgConfig::CAIRO.

option(CUBE_COLLISION_WITH_CAIRO "Build the SVG/PNG export of the hierarchy (needs Cairo)" ON)

set(CUBE_COLLISION_HAS_CAIRO OFF)
if(CUBE_COLLISION_WITH_CAIRO)
  find_package(PkgConfig QUIET)
  if(PkgConfig_FOUND)
    pkg_check_modules(CAIRO QUIET IMPORTED_TARGET cairo)
  endif()
  if(TARGET PkgConfig::CAIRO)
    set(CUBE_COLLISION_HAS_CAIRO ON)
    message(STATUS "cube_collision: Cairo ${CAIRO_VERSION} found: SVG/PNG export enabled")
  else()
    message(STATUS "cube_collision: Cairo not found (install libcairo2-dev and pkg-config): "
                   "the SVG/PNG export of the hierarchy is left out; OBJ export remains")
  endif()
else()
  message(STATUS "cube_collision: CUBE_COLLISION_WITH_CAIRO is OFF: SVG/PNG export left out")
endif()
