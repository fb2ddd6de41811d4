// Draws the cube hierarchy of a scene: writes cubes.png, cubes.svg (when built with Cairo) and
// cubes.obj, and prints the hierarchy's statistics.
//
//   draw_hierarchy [objects] [output-directory] [--view iso|top|front] [--size WxH]
//                  [--leaf-size k] [--max-depth d] [--layout clustered|uniform|thin]
//                  [--seed s] [--object-scale f] [--max-level l] [--no-objects]
//
// Defaults: 300 objects in clustered blobs, isometric view, 1024x768, current directory.

#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/export.h"
#include "cube_collision/inspect.h"
#include "scenes.h"

namespace {

int usage(const char* why) {
  std::cerr << "draw_hierarchy: " << why << "\n"
            << "usage: draw_hierarchy [objects] [output-directory] [--view iso|top|front]\n"
               "                      [--size WxH] [--leaf-size k] [--max-depth d]\n"
               "                      [--layout clustered|uniform|thin] [--seed s]\n"
               "                      [--object-scale f] [--max-level l] [--no-objects]\n";
  return 2;
}

bool isCount(const char* s) {
  if (*s == '\0') return false;
  for (const char* p = s; *p; ++p)
    if (*p < '0' || *p > '9') return false;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  cube::scenes::SceneOptions scene_options;
  scene_options.n = 300;
  scene_options.layout = cube::scenes::Layout::clustered;
  cube::Config config;
  cube::ImageOptions image;
  std::string dir = ".";
  bool have_count = false, have_dir = false;

  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--view" && has_value) {
      const std::string v = argv[++i];
      if (v == "iso" || v == "isometric") {
        image.view = cube::ViewDirection::isometric;
      } else if (v == "top") {
        image.view = cube::ViewDirection::top;
      } else if (v == "front") {
        image.view = cube::ViewDirection::front;
      } else {
        return usage("unknown view");
      }
    } else if (a == "--size" && has_value) {
      if (std::sscanf(argv[++i], "%dx%d", &image.width, &image.height) != 2)
        return usage("--size wants WxH");
    } else if (a == "--leaf-size" && has_value) {
      config.leaf_size = std::atoi(argv[++i]);
    } else if (a == "--max-depth" && has_value) {
      config.max_depth = std::atoi(argv[++i]);
    } else if (a == "--seed" && has_value) {
      scene_options.seed = static_cast<std::uint32_t>(std::strtoul(argv[++i], nullptr, 10));
    } else if (a == "--layout" && has_value) {
      const std::string l = argv[++i];
      if (l == "clustered") {
        scene_options.layout = cube::scenes::Layout::clustered;
      } else if (l == "uniform") {
        scene_options.layout = cube::scenes::Layout::uniform;
      } else if (l == "thin") {
        scene_options.layout = cube::scenes::Layout::thin;
      } else {
        return usage("unknown layout");
      }
    } else if (a == "--object-scale" && has_value) {
      scene_options.size_scale = std::atof(argv[++i]);
    } else if (a == "--max-level" && has_value) {
      image.max_level = std::atoi(argv[++i]);
    } else if (a == "--no-objects") {
      image.draw_objects = false;
    } else if (a.rfind("--", 0) == 0) {
      return usage(("unknown or incomplete option " + a).c_str());
    } else if (!have_count && isCount(argv[i])) {
      scene_options.n = std::strtoul(argv[i], nullptr, 10);
      have_count = true;
    } else if (!have_dir) {
      dir = a;
      have_dir = true;
    } else {
      return usage(("unexpected argument " + a).c_str());
    }
  }

  try {
    auto scene = cube::scenes::makeScene<double>(scene_options);
    cube::CubeCollisionManager<double> manager(config);
    manager.registerObjects(scene.pointers());
    manager.setup();

    const cube::HierarchyView<double> view(manager);
    std::cout << view.stats();

    const std::string base = dir + "/cubes";
    cube::writeObj(view, base + ".obj");
    std::cout << "wrote " << base << ".obj\n";
#if defined(CUBE_COLLISION_HAS_CAIRO)
    cube::writePng(view, base + ".png", image);
    std::cout << "wrote " << base << ".png\n";
    cube::writeSvg(view, base + ".svg", image);
    std::cout << "wrote " << base << ".svg\n";
#else
    std::cout << "built without Cairo: no PNG or SVG (install libcairo2-dev and reconfigure)\n";
#endif
  } catch (const std::exception& e) {
    std::cerr << "draw_hierarchy: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
