// OBJ wireframe of the cubes: plain text, one group per level so that viewers can hide levels.

#include <fstream>
#include <limits>
#include <ostream>
#include <stdexcept>

#include "cube_collision/export.h"

namespace cube {

template <typename S>
void writeObj(const HierarchyView<S>& view, std::ostream& out) {
  const int cubes = view.getNumberCells();
  out << "# cube_collision hierarchy: " << cubes << " cubes, " << view.levelCount() << " levels, "
      << view.objects().size() << " objects\n";
  out << "# each cube: 8 vertices and 12 edges; group level_<l> holds the cubes of level l\n";
  // Round-trip precision: the corners are the exact float bounds the queries use.
  const std::streamsize precision = out.precision(std::numeric_limits<float>::max_digits10);
  long base = 1;  // OBJ vertex numbers start at 1
  for (int l = 0; l < view.levelCount(); ++l) {
    out << "g level_" << l << "\n";
    const std::pair<int, int> range = view.levelCubes(l);
    for (int i = range.first; i < range.second; ++i) {
      const CubeData& c = view.getCubeData(i);
      // Corner k has x from bit 0, y from bit 1, z from bit 2.
      for (int k = 0; k < 8; ++k)
        out << "v " << (k & 1 ? c.max[0] : c.min[0]) << ' ' << (k & 2 ? c.max[1] : c.min[1]) << ' '
            << (k & 4 ? c.max[2] : c.min[2]) << "\n";
      // An edge joins two corners that differ in exactly one bit.
      for (int k = 0; k < 8; ++k)
        for (int bit = 1; bit < 8; bit <<= 1)
          if (!(k & bit)) out << "l " << base + k << ' ' << base + (k | bit) << "\n";
      base += 8;
    }
  }
  out.precision(precision);
}

template <typename S>
void writeObj(const HierarchyView<S>& view, const std::string& path) {
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cube::writeObj: cannot open " + path);
  writeObj(view, static_cast<std::ostream&>(file));
  file.close();
  if (!file) throw std::runtime_error("cube::writeObj: cannot write " + path);
}

template void writeObj<float>(const HierarchyView<float>&, std::ostream&);
template void writeObj<double>(const HierarchyView<double>&, std::ostream&);
template void writeObj<float>(const HierarchyView<float>&, const std::string&);
template void writeObj<double>(const HierarchyView<double>&, const std::string&);

}  // namespace cube
