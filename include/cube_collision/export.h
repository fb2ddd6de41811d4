#pragma once

// Pictures of a cube hierarchy: an OBJ wireframe (any 3D viewer) and, when the library was built
// with Cairo (CUBE_COLLISION_HAS_CAIRO is defined), SVG and PNG drawings. Every cube is drawn as
// the 12 edges of its box, coloured by level, each level 0.8 times as opaque as the one above,
// so that deep levels show through shallow ones.

#include <iosfwd>
#include <string>

#include "cube_collision/inspect.h"

namespace cube {

/// Writes the cubes as an OBJ wireframe: one group `level_<l>` per level, each cube as 8
/// vertices `v` and its 12 edges as `l` lines. Comment lines give the counts.
template <typename S>
void writeObj(const HierarchyView<S>& view, std::ostream& out);

/// Same, to a file. Throws std::runtime_error if the file cannot be written.
template <typename S>
void writeObj(const HierarchyView<S>& view, const std::string& path);

/// Direction the image looks from; all are orthographic.
enum class ViewDirection {
  top,        ///< from +z: x to the right, y up
  front,      ///< from -y: x to the right, z up
  isometric,  ///< from (+1, -1, +1): x to the lower right, y to the upper right, z up
};

/// How to draw an image of the hierarchy.
struct ImageOptions {
  int width = 1024;  ///< pixels (PNG) or px user units (SVG); at least 16
  int height = 768;  ///< at least 16
  ViewDirection view = ViewDirection::isometric;
  /// Draw every object's AABB faintly under the cubes.
  bool draw_objects = true;
  /// Draw a legend of the level colours and the cube/object counts.
  bool legend = true;
  /// Deepest level drawn; -1 draws all.
  int max_level = -1;
  /// Opacity of the root's lines; each level below multiplies it by `alpha_decay`.
  double root_alpha = 1.0;
  double alpha_decay = 0.8;
  /// Width in pixels of the root's lines; deeper lines are thinner, down to 0.4 of it.
  double line_width = 2.0;
  /// Free space kept around the scene, in pixels (at most an eighth of the smaller side).
  int margin = 24;
  /// White background; false leaves it transparent.
  bool background = true;
};

#if defined(CUBE_COLLISION_HAS_CAIRO)
/// Draws the hierarchy to an SVG file of width x height px. Throws std::invalid_argument for
/// options out of range, std::runtime_error if Cairo cannot write the file.
template <typename S>
void writeSvg(const HierarchyView<S>& view, const std::string& path,
              const ImageOptions& options = ImageOptions());

/// Draws the hierarchy to a PNG file of width x height pixels, 8 bits per channel: RGB, or RGBA
/// when `background` is false. Throws as writeSvg.
template <typename S>
void writePng(const HierarchyView<S>& view, const std::string& path,
              const ImageOptions& options = ImageOptions());
#endif

}  // namespace cube
