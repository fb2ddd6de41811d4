// Exporters: the OBJ parsed back against the inspection snapshot; the PNG's chunks (signature,
// IHDR, CRCs) decoded by hand and its pixels read back with Cairo; the SVG checked for balanced
// tags and its declared size.

#include <fcl/geometry/shape/box.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/export.h"
#include "cube_collision/inspect.h"
#include "scenes.h"

#if defined(CUBE_COLLISION_HAS_CAIRO)
#include <cairo.h>
#endif

namespace {

using cube::CubeCollisionManager;
using cube::HierarchyView;

struct SceneFixture {
  cube::scenes::Scene<double> scene;
  CubeCollisionManager<double> manager;
  explicit SceneFixture(std::size_t n, cube::Config cfg = cube::Config()) : manager(cfg) {
    cube::scenes::SceneOptions opt;
    opt.n = n;
    opt.layout = cube::scenes::Layout::clustered;
    opt.seed = 11;
    scene = cube::scenes::makeScene<double>(opt);
    manager.registerObjects(scene.pointers());
    manager.setup();
  }
};

std::string tempPath(const std::string& name) {
  const char* dir = std::getenv("TMPDIR");
  const ::testing::TestInfo* t = ::testing::UnitTest::GetInstance()->current_test_info();
  return std::string(dir && *dir ? dir : "/tmp") + "/cube_export_" + t->name() + "_" + name;
}

std::string readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// ---------------------------------------------------------------------------------------------
// OBJ

struct ParsedObj {
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::pair<long, long>> edges;
  std::vector<std::string> groups;
  std::vector<std::size_t> vertices_per_group;
};

ParsedObj parseObj(const std::string& text) {
  ParsedObj p;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      std::array<double, 3> v{};
      ls >> v[0] >> v[1] >> v[2];
      EXPECT_FALSE(ls.fail()) << line;
      p.vertices.push_back(v);
      if (!p.vertices_per_group.empty()) ++p.vertices_per_group.back();
    } else if (tag == "l") {
      long a = 0, b = 0;
      ls >> a >> b;
      EXPECT_FALSE(ls.fail()) << line;
      p.edges.emplace_back(a, b);
    } else if (tag == "g") {
      std::string name;
      ls >> name;
      p.groups.push_back(name);
      p.vertices_per_group.push_back(0);
    } else {
      ADD_FAILURE() << "unexpected OBJ line: " << line;
    }
  }
  return p;
}

TEST(ExportObj, EightVerticesTwelveEdgesPerCubeOneGroupPerLevel) {
  SceneFixture f(250);
  HierarchyView<double> view(f.manager);
  ASSERT_GT(view.levelCount(), 3);
  std::ostringstream out;
  cube::writeObj(view, out);
  const ParsedObj obj = parseObj(out.str());
  const std::size_t n = std::size_t(view.getNumberCells());
  EXPECT_EQ(obj.vertices.size(), 8 * n);
  EXPECT_EQ(obj.edges.size(), 12 * n);
  ASSERT_EQ(obj.groups.size(), std::size_t(view.levelCount()));
  for (int l = 0; l < view.levelCount(); ++l) {
    EXPECT_EQ(obj.groups[std::size_t(l)], "level_" + std::to_string(l));
    const auto r = view.levelCubes(l);
    EXPECT_EQ(obj.vertices_per_group[std::size_t(l)], 8 * std::size_t(r.second - r.first));
  }
  // Level order is cube-number order (levels are contiguous), so cube i owns vertices 8i+1..8i+8.
  for (std::size_t i = 0; i < n; ++i) {
    const cube::CubeData& c = view.getCubeData(int(i));
    std::set<std::array<double, 3>> corners;
    for (std::size_t k = 0; k < 8; ++k) {
      const auto& v = obj.vertices[8 * i + k];
      for (int a = 0; a < 3; ++a) {
        // Corners are floats written with enough digits to read back exactly.
        EXPECT_TRUE(float(v[a]) == float(c.min[a]) || float(v[a]) == float(c.max[a]))
            << "cube " << i << " vertex " << k;
      }
      corners.insert(v);
    }
    if (c.max[0] > c.min[0] && c.max[1] > c.min[1] && c.max[2] > c.min[2]) {
      EXPECT_EQ(corners.size(), 8u) << "cube " << i;
    }
    std::set<std::pair<long, long>> edges;
    for (std::size_t e = 0; e < 12; ++e) {
      const auto& ed = obj.edges[12 * i + e];
      const long lo = long(8 * i) + 1, hi = long(8 * i) + 8;
      ASSERT_TRUE(ed.first >= lo && ed.first <= hi && ed.second >= lo && ed.second <= hi)
          << "edge of cube " << i << " leaves its vertices";
      const auto& p = obj.vertices[std::size_t(ed.first - 1)];
      const auto& q = obj.vertices[std::size_t(ed.second - 1)];
      int differ = 0;
      for (int a = 0; a < 3; ++a) differ += p[a] != q[a];
      EXPECT_LE(differ, 1) << "cube " << i << " edge " << e << " is not axis-aligned";
      edges.insert(std::minmax(ed.first, ed.second));
    }
    EXPECT_EQ(edges.size(), 12u) << "cube " << i << " repeats an edge";
  }
}

TEST(ExportObj, FileMatchesStreamAndReportsErrors) {
  SceneFixture f(40);
  HierarchyView<double> view(f.manager);
  std::ostringstream out;
  cube::writeObj(view, out);
  const std::string path = tempPath("cubes.obj");
  cube::writeObj(view, path);
  EXPECT_EQ(readFile(path), out.str());
  std::remove(path.c_str());
  EXPECT_THROW(cube::writeObj(view, std::string("/nonexistent-dir/cubes.obj")), std::runtime_error);
}

TEST(ExportObj, EmptyHierarchyHasNoCubes) {
  CubeCollisionManager<float> m;
  HierarchyView<float> view(m);
  std::ostringstream out;
  cube::writeObj(view, out);
  const ParsedObj obj = parseObj(out.str());
  EXPECT_TRUE(obj.vertices.empty());
  EXPECT_TRUE(obj.edges.empty());
  EXPECT_TRUE(obj.groups.empty());
}

#if defined(CUBE_COLLISION_HAS_CAIRO)

// ---------------------------------------------------------------------------------------------
// PNG: chunk structure and CRCs, decoded by hand (no zlib needed for the header).

std::uint32_t crc32(const unsigned char* p, std::size_t n) {
  std::uint32_t c = 0xffffffffu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return c ^ 0xffffffffu;
}

std::uint32_t be32(const unsigned char* p) {
  return std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3];
}

struct PngHeader {
  std::uint32_t width = 0, height = 0;
  int bit_depth = 0, colour_type = 0;
  bool valid = false;
};

PngHeader checkPng(const std::string& bytes) {
  PngHeader h;
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  static const unsigned char kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 8 + 25 + 12 || !std::equal(kSig, kSig + 8, b)) {
    ADD_FAILURE() << "no PNG signature";
    return h;
  }
  std::size_t pos = 8;
  bool first = true, ended = false, saw_data = false;
  while (pos + 12 <= bytes.size() && !ended) {
    const std::uint32_t len = be32(b + pos);
    if (pos + 12 + len > bytes.size()) {
      ADD_FAILURE() << "chunk runs past the end";
      return h;
    }
    const std::string type(bytes, pos + 4, 4);
    if (crc32(b + pos + 4, 4 + len) != be32(b + pos + 8 + len)) {
      ADD_FAILURE() << "bad CRC in chunk " << type;
      return h;
    }
    if (first) {
      if (type != "IHDR" || len != 13) {
        ADD_FAILURE() << "first chunk is " << type << ", not a 13-byte IHDR";
        return h;
      }
      h.width = be32(b + pos + 8);
      h.height = be32(b + pos + 12);
      h.bit_depth = b[pos + 16];
      h.colour_type = b[pos + 17];
      first = false;
    }
    saw_data |= type == "IDAT";
    ended = type == "IEND";
    pos += 12 + len;
  }
  EXPECT_TRUE(saw_data) << "no IDAT chunk";
  EXPECT_TRUE(ended) << "no IEND chunk";
  EXPECT_EQ(pos, bytes.size()) << "bytes after IEND";
  h.valid = saw_data && ended && pos == bytes.size();
  return h;
}

// Pixels read back with Cairo (already a dependency of the library), premultiplied ARGB.
struct Pixels {
  int width = 0, height = 0;
  std::vector<std::uint32_t> argb;
  explicit Pixels(const std::string& path) {
    cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
      width = cairo_image_surface_get_width(s);
      height = cairo_image_surface_get_height(s);
      const int stride = cairo_image_surface_get_stride(s);
      const unsigned char* data = cairo_image_surface_get_data(s);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          argb.push_back(*reinterpret_cast<const std::uint32_t*>(data + y * stride + 4 * x));
    }
    cairo_surface_destroy(s);
  }
  std::uint32_t at(int x, int y) const { return argb[std::size_t(y) * std::size_t(width) + x]; }
  // How far a pixel is from opaque white, summed over the channels.
  int ink(int x, int y) const {
    const std::uint32_t p = at(x, y);
    return 3 * 255 - int((p >> 16) & 255) - int((p >> 8) & 255) - int(p & 255);
  }
  long totalInk() const {
    long t = 0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) t += ink(x, y);
    return t;
  }
};

TEST(ExportPng, ValidFileOfTheRequestedSize) {
  SceneFixture f(200);
  HierarchyView<double> view(f.manager);
  cube::ImageOptions o;
  o.width = 333;
  o.height = 217;
  for (cube::ViewDirection d :
       {cube::ViewDirection::isometric, cube::ViewDirection::top, cube::ViewDirection::front}) {
    o.view = d;
    const std::string path = tempPath("cubes.png");
    cube::writePng(view, path, o);
    const PngHeader h = checkPng(readFile(path));
    EXPECT_TRUE(h.valid);
    EXPECT_EQ(h.width, 333u);
    EXPECT_EQ(h.height, 217u);
    EXPECT_EQ(h.bit_depth, 8);
    EXPECT_EQ(h.colour_type, 2);  // RGB: the white background is opaque
    const Pixels px(path);
    EXPECT_EQ(px.width, 333);
    EXPECT_EQ(px.height, 217);
    EXPECT_GT(px.totalInk(), 0) << "nothing drawn";
    std::remove(path.c_str());
  }
}

// The root cube, which holds everything, fills the drawing area along one axis and is centred.
TEST(ExportPng, SceneIsFittedToTheImage) {
  SceneFixture f(120);
  HierarchyView<double> view(f.manager);
  cube::ImageOptions o;
  o.width = 400;
  o.height = 300;
  o.margin = 20;
  o.legend = false;
  o.draw_objects = false;
  for (cube::ViewDirection d :
       {cube::ViewDirection::isometric, cube::ViewDirection::top, cube::ViewDirection::front}) {
    o.view = d;
    const std::string path = tempPath("fit.png");
    cube::writePng(view, path, o);
    const Pixels px(path);
    ASSERT_EQ(px.width, 400);
    int x0 = px.width, x1 = -1, y0 = px.height, y1 = -1;
    for (int y = 0; y < px.height; ++y)
      for (int x = 0; x < px.width; ++x)
        if (px.ink(x, y) > 60) {
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
    ASSERT_GE(x1, 0) << "blank image";
    // Lines are ~2 px wide and antialiased: allow 3 px of slack.
    EXPECT_GE(x0, 20 - 3);
    EXPECT_LE(x1, 380 + 3);
    EXPECT_GE(y0, 20 - 3);
    EXPECT_LE(y1, 280 + 3);
    const bool fills_width = x0 <= 20 + 3 && x1 >= 380 - 3;
    const bool fills_height = y0 <= 20 + 3 && y1 >= 280 - 3;
    EXPECT_TRUE(fills_width || fills_height) << x0 << ".." << x1 << " x " << y0 << ".." << y1;
    EXPECT_NEAR(0.5 * (x0 + x1), 200, 3);
    EXPECT_NEAR(0.5 * (y0 + y1), 150, 3);
    std::remove(path.c_str());
  }
}

// Deeper levels are fainter: faster decay means less ink; drawing only the root, even less.
TEST(ExportPng, TransparencyGrowsWithDepth) {
  SceneFixture f(150);
  HierarchyView<double> view(f.manager);
  cube::ImageOptions o;
  o.width = 300;
  o.height = 300;
  o.legend = false;
  o.draw_objects = false;
  auto ink = [&](double decay, int max_level) {
    o.alpha_decay = decay;
    o.max_level = max_level;
    const std::string path = tempPath("alpha.png");
    cube::writePng(view, path, o);
    const long t = Pixels(path).totalInk();
    std::remove(path.c_str());
    return t;
  };
  const long opaque = ink(1.0, -1), seed = ink(0.8, -1), steep = ink(0.4, -1), root = ink(0.8, 0);
  EXPECT_GT(opaque, seed);
  EXPECT_GT(seed, steep);
  EXPECT_GT(steep, root);
  EXPECT_GT(root, 0);
  // Objects add ink underneath.
  o.draw_objects = true;
  EXPECT_GT(ink(0.8, -1), seed);
}

TEST(ExportPng, TransparentBackgroundAndEmptyHierarchy) {
  CubeCollisionManager<float> m;
  HierarchyView<float> view(m);
  cube::ImageOptions o;
  o.width = 64;
  o.height = 48;
  o.background = false;
  o.legend = false;
  const std::string path = tempPath("empty.png");
  cube::writePng(view, path, o);
  const PngHeader h = checkPng(readFile(path));
  EXPECT_TRUE(h.valid);
  EXPECT_EQ(h.width, 64u);
  EXPECT_EQ(h.height, 48u);
  EXPECT_EQ(h.colour_type, 6);  // RGBA
  const Pixels px(path);
  ASSERT_EQ(px.width, 64);
  EXPECT_EQ(px.at(0, 0) >> 24, 0u) << "background should be transparent";
  std::remove(path.c_str());
}

TEST(ExportImage, BadOptionsAndPathsThrow) {
  SceneFixture f(20);
  HierarchyView<double> view(f.manager);
  const std::string path = tempPath("bad.png");
  cube::ImageOptions o;
  o.width = 0;
  EXPECT_THROW(cube::writePng(view, path, o), std::invalid_argument);
  EXPECT_THROW(cube::writeSvg(view, path, o), std::invalid_argument);
  o = cube::ImageOptions();
  o.alpha_decay = 0;
  EXPECT_THROW(cube::writePng(view, path, o), std::invalid_argument);
  o = cube::ImageOptions();
  o.margin = -1;
  EXPECT_THROW(cube::writePng(view, path, o), std::invalid_argument);
  EXPECT_THROW(cube::writePng(view, "/nonexistent-dir/cubes.png"), std::runtime_error);
  EXPECT_THROW(cube::writeSvg(view, "/nonexistent-dir/cubes.svg"), std::runtime_error);
}

// ---------------------------------------------------------------------------------------------
// SVG: well-formed (balanced tags, one root) and of the requested size.

struct XmlCheck {
  bool ok = true;
  std::string error;
  std::string root;
  std::string root_tag;  // the root's start tag, attributes included
  std::size_t elements = 0;
  std::size_t paths = 0;
};

XmlCheck checkXml(const std::string& s) {
  XmlCheck r;
  auto fail = [&](const std::string& e) {
    r.ok = false;
    r.error = e;
    return r;
  };
  std::vector<std::string> open;
  bool root_closed = false;
  std::size_t pos = 0;
  while ((pos = s.find('<', pos)) != std::string::npos) {
    if (s.compare(pos, 4, "<!--") == 0) {
      const std::size_t e = s.find("-->", pos);
      if (e == std::string::npos) return fail("unterminated comment");
      pos = e + 3;
      continue;
    }
    if (s.compare(pos, 2, "<?") == 0 || s.compare(pos, 2, "<!") == 0) {
      const std::size_t e = s.find('>', pos);
      if (e == std::string::npos) return fail("unterminated declaration");
      pos = e + 1;
      continue;
    }
    // Find the end of the tag, skipping quoted attribute values.
    std::size_t e = pos + 1;
    char quote = 0;
    for (; e < s.size(); ++e) {
      if (quote) {
        if (s[e] == quote) quote = 0;
      } else if (s[e] == '"' || s[e] == '\'') {
        quote = s[e];
      } else if (s[e] == '>') {
        break;
      } else if (s[e] == '<') {
        return fail("'<' inside a tag");
      }
    }
    if (e >= s.size()) return fail("unterminated tag");
    const std::string tag = s.substr(pos + 1, e - pos - 1);
    pos = e + 1;
    if (tag.empty()) return fail("empty tag");
    if (tag[0] == '/') {
      const std::string name = tag.substr(1, tag.find_first_of(" \t\r\n", 1) - 1);
      if (open.empty() || open.back() != name)
        return fail("</" + name + "> closes " + (open.empty() ? "nothing" : open.back()));
      open.pop_back();
      if (open.empty()) root_closed = true;
      continue;
    }
    const std::string name = tag.substr(0, tag.find_first_of(" \t\r\n/"));
    if (name.empty()) return fail("nameless tag");
    if (open.empty()) {
      if (root_closed || !r.root.empty()) return fail("second root element " + name);
      r.root = name;
      r.root_tag = tag;
    }
    ++r.elements;
    r.paths += name == "path";
    if (tag.back() != '/') {
      open.push_back(name);
    } else if (open.empty()) {
      root_closed = true;
    }
  }
  if (!open.empty()) return fail("unclosed <" + open.back() + ">");
  if (r.root.empty()) return fail("no root element");
  return r;
}

// Value of attribute `name` in a start tag, as a number (units such as px ignored); -1 if absent.
double attribute(const std::string& tag, const std::string& name) {
  const std::size_t p = tag.find(" " + name + "=\"");
  if (p == std::string::npos) return -1;
  return std::strtod(tag.c_str() + p + name.size() + 3, nullptr);
}

TEST(XmlChecker, RejectsMalformedDocuments) {
  // The checker itself must be able to fail, or the SVG test proves nothing.
  EXPECT_TRUE(
      checkXml("<?xml version=\"1.0\"?><svg a=\"x>y\"><g><path d=\"M 0 0\"/></g></svg>").ok);
  EXPECT_FALSE(checkXml("<svg><g></svg>").ok);
  EXPECT_FALSE(checkXml("<svg><g></g>").ok);
  EXPECT_FALSE(checkXml("<svg></svg><svg></svg>").ok);
  EXPECT_FALSE(checkXml("<svg><g</svg>").ok);
  EXPECT_FALSE(checkXml("no markup").ok);
}

TEST(ExportSvg, WellFormedAndOfTheRequestedSize) {
  SceneFixture f(150);
  HierarchyView<double> view(f.manager);
  cube::ImageOptions o;
  o.width = 640;
  o.height = 480;
  o.view = cube::ViewDirection::front;
  const std::string path = tempPath("cubes.svg");
  cube::writeSvg(view, path, o);
  const std::string svg = readFile(path);
  std::remove(path.c_str());
  ASSERT_FALSE(svg.empty());
  EXPECT_EQ(svg.compare(0, 5, "<?xml"), 0);
  const XmlCheck x = checkXml(svg);
  ASSERT_TRUE(x.ok) << x.error;
  EXPECT_EQ(x.root, "svg");
  EXPECT_EQ(attribute(x.root_tag, "width"), 640);
  EXPECT_EQ(attribute(x.root_tag, "height"), 480);
  EXPECT_NE(x.root_tag.find("viewBox=\"0 0 640 480\""), std::string::npos) << x.root_tag;
  // One stroke per drawn level plus the objects' outlines; text glyphs add more paths.
  EXPECT_GE(x.paths, std::size_t(view.levelCount()));
}

#endif  // CUBE_COLLISION_HAS_CAIRO

}  // namespace
