// SVG and PNG drawings of the cubes with Cairo: orthographic views, scene fitted to the image,
// one stroke per level so that overlapping edges of a level do not darken each other.

#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cube_collision/export.h"

namespace cube {

namespace {

struct SurfaceFree {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextFree {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using Surface = std::unique_ptr<cairo_surface_t, SurfaceFree>;
using Context = std::unique_ptr<cairo_t, ContextFree>;

struct Point {
  double x, y;
};

// Orthographic camera: screen right and up axes in world coordinates.
struct Camera {
  std::array<double, 3> right, up;
  Point project(double x, double y, double z) const {
    return {right[0] * x + right[1] * y + right[2] * z, up[0] * x + up[1] * y + up[2] * z};
  }
};

Camera cameraFor(ViewDirection v) {
  switch (v) {
    case ViewDirection::top:
      return {{1, 0, 0}, {0, 1, 0}};
    case ViewDirection::front:
      return {{1, 0, 0}, {0, 0, 1}};
    case ViewDirection::isometric:
      break;
  }
  // Looking from (1, -1, 1): right = (1, 1, 0) / sqrt 2, up = (-1, 1, 2) / sqrt 6.
  const double r = 1 / std::sqrt(2.0), u = 1 / std::sqrt(6.0);
  return {{r, r, 0}, {-u, u, 2 * u}};
}

const char* viewName(ViewDirection v) {
  switch (v) {
    case ViewDirection::top:
      return "top view";
    case ViewDirection::front:
      return "front view";
    case ViewDirection::isometric:
      break;
  }
  return "isometric view";
}

// Distinct colours that stay readable on white when faded (Tableau 10, grey left out).
// Saturated colours that stay readable on white when faded; the deeper levels, drawn faintest,
// get the darker ones.
constexpr std::array<std::array<double, 3>, 9> kPalette{{{0.122, 0.467, 0.706},
                                                         {0.839, 0.153, 0.157},
                                                         {0.173, 0.627, 0.173},
                                                         {0.929, 0.420, 0.000},
                                                         {0.459, 0.243, 0.667},
                                                         {0.000, 0.502, 0.502},
                                                         {0.545, 0.271, 0.075},
                                                         {0.749, 0.000, 0.549},
                                                         {0.200, 0.200, 0.200}}};

struct Style {
  std::array<double, 3> rgb;
  double alpha, width;
};

Style levelStyle(const ImageOptions& o, int level) {
  const auto& c = kPalette[static_cast<std::size_t>(level) % kPalette.size()];
  return {c, o.root_alpha * std::pow(o.alpha_decay, level),
          o.line_width * std::max(0.4, std::pow(0.85, level))};
}

// Maps scene coordinates to image pixels (y down), fitted into a rectangle.
struct Fit {
  double scale = 1, ox = 0, oy = 0;
  Point toImage(Point p) const { return {ox + scale * p.x, oy - scale * p.y}; }
};

void corners(const std::array<double, 3>& lo, const std::array<double, 3>& hi, const Camera& cam,
             const Fit& fit, Point out[8]) {
  for (int k = 0; k < 8; ++k)
    out[k] = fit.toImage(
        cam.project(k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]));
}

double cross(const Point& o, const Point& a, const Point& b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Outline of a projected box: convex hull of its corners (monotone chain).
int hull(Point p[8], Point out[16]) {
  std::sort(p, p + 8,
            [](const Point& a, const Point& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  int n = 0;
  for (int i = 0; i < 8; ++i) {
    while (n >= 2 && cross(out[n - 2], out[n - 1], p[i]) <= 0) --n;
    out[n++] = p[i];
  }
  for (int i = 6, low = n + 1; i >= 0; --i) {
    while (n >= low && cross(out[n - 2], out[n - 1], p[i]) <= 0) --n;
    out[n++] = p[i];
  }
  return n - 1;
}

void checkOptions(const ImageOptions& o) {
  auto bad = [](const char* what) {
    throw std::invalid_argument(std::string("cube image export: ") + what);
  };
  if (o.width < 16 || o.height < 16 || o.width > 32768 || o.height > 32768)
    bad("width and height must be in [16, 32768]");
  if (o.margin < 0) bad("margin must not be negative");
  if (!(o.root_alpha > 0 && o.root_alpha <= 1)) bad("root_alpha must be in (0, 1]");
  if (!(o.alpha_decay > 0 && o.alpha_decay <= 1)) bad("alpha_decay must be in (0, 1]");
  if (!(o.line_width > 0 && o.line_width < 100)) bad("line_width must be in (0, 100)");
}

template <typename S>
void draw(const HierarchyView<S>& view, const ImageOptions& o, cairo_t* cr) {
  const Camera cam = cameraFor(o.view);
  const int levels =
      o.max_level < 0 ? view.levelCount() : std::min(view.levelCount(), o.max_level + 1);
  // Small images keep most of their area for the scene.
  const double margin = std::min(double(o.margin), std::min(o.width, o.height) / 8.0);
  const double legend_h = o.legend ? std::min(30.0, o.height / 4.0) : 0.0;

  if (o.background) {
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
  }

  // Fit the root cube (which holds every object) into the drawing area.
  Fit fit;
  if (view.getNumberCells() > 0) {
    const CubeData& root = view.getCubeData(0);
    double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
    for (int k = 0; k < 8; ++k) {
      const Point p =
          cam.project(k & 1 ? root.max[0] : root.min[0], k & 2 ? root.max[1] : root.min[1],
                      k & 4 ? root.max[2] : root.min[2]);
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y),
      y1 = std::max(y1, p.y);
    }
    const double aw = o.width - 2 * margin, ah = o.height - 2 * margin - legend_h;
    const double span = std::max({x1 - x0, y1 - y0, 1e-30});
    fit.scale = std::min(aw / std::max(x1 - x0, span * 1e-6), ah / std::max(y1 - y0, span * 1e-6));
    fit.ox = margin + 0.5 * aw - fit.scale * 0.5 * (x0 + x1);
    fit.oy = margin + 0.5 * ah + fit.scale * 0.5 * (y0 + y1);
  }

  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  Point c[8], h[16];

  if (o.draw_objects && !view.objects().empty()) {
    // All outlines in one path: the union is tinted once, however many objects overlap.
    for (std::size_t k = 0; k < view.objects().size(); ++k) {
      const BoundingBox& b = view.objectBox(static_cast<int>(k));
      corners(b.first, b.second, cam, fit, c);
      const int n = hull(c, h);
      cairo_move_to(cr, h[0].x, h[0].y);
      for (int i = 1; i < n; ++i) cairo_line_to(cr, h[i].x, h[i].y);
      cairo_close_path(cr);
    }
    cairo_set_fill_rule(cr, CAIRO_FILL_RULE_WINDING);
    cairo_set_source_rgba(cr, 0.35, 0.38, 0.42, 0.22);
    cairo_fill_preserve(cr);
    cairo_set_source_rgba(cr, 0.35, 0.38, 0.42, 0.45);
    cairo_set_line_width(cr, 0.6);
    cairo_stroke(cr);
  }

  // Deepest level first, so that the coarse structure stays on top.
  for (int l = levels - 1; l >= 0; --l) {
    const std::pair<int, int> range = view.levelCubes(l);
    for (int i = range.first; i < range.second; ++i) {
      const CubeData& d = view.getCubeData(i);
      corners(d.min, d.max, cam, fit, c);
      for (int k = 0; k < 8; ++k)
        for (int bit = 1; bit < 8; bit <<= 1)
          // Edges seen end-on (vertical ones in the top view) would leave dots at the corners.
          if (!(k & bit) &&
              std::fabs(c[k].x - c[k | bit].x) + std::fabs(c[k].y - c[k | bit].y) > 1e-3) {
            cairo_move_to(cr, c[k].x, c[k].y);
            cairo_line_to(cr, c[k | bit].x, c[k | bit].y);
          }
    }
    const Style s = levelStyle(o, l);
    cairo_set_source_rgba(cr, s.rgb[0], s.rgb[1], s.rgb[2], s.alpha);
    cairo_set_line_width(cr, s.width);
    cairo_stroke(cr);
  }

  if (!o.legend) return;
  // One line at the bottom: a swatch per level, then the counts.
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 13);
  double x = margin;
  const double y = o.height - margin * 0.5 - 8;
  auto text = [&](const std::string& t, double r, double g, double b) {
    cairo_set_source_rgb(cr, r, g, b);
    cairo_move_to(cr, x, y);
    cairo_show_text(cr, t.c_str());
    cairo_text_extents_t e;
    cairo_text_extents(cr, t.c_str(), &e);
    x += e.x_advance;
  };
  text("levels ", 0.2, 0.2, 0.2);
  for (int l = 0; l < levels; ++l) {
    const Style s = levelStyle(o, l);
    cairo_set_source_rgba(cr, s.rgb[0], s.rgb[1], s.rgb[2], s.alpha);
    cairo_set_line_width(cr, std::max(3.0, 2 * s.width));
    cairo_move_to(cr, x + 2, y - 4);
    cairo_line_to(cr, x + 18, y - 4);
    cairo_stroke(cr);
    x += 21;
    text(std::to_string(l) + "  ", 0.2, 0.2, 0.2);
  }
  const HierarchyStats& st = view.stats();
  text("   " + std::to_string(st.cubes) + " cubes, " + std::to_string(st.leaves) + " leaves, " +
           std::to_string(st.objects) + " objects, " + viewName(o.view),
       0.35, 0.35, 0.35);
}

void check(cairo_status_t status, const char* what, const std::string& path) {
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(std::string("cube::") + what + ": " + path + ": " +
                             cairo_status_to_string(status));
}

}  // namespace

template <typename S>
void writeSvg(const HierarchyView<S>& view, const std::string& path, const ImageOptions& options) {
  checkOptions(options);
  Surface surface(cairo_svg_surface_create(path.c_str(), options.width, options.height));
  check(cairo_surface_status(surface.get()), "writeSvg", path);
  // Pixels rather than Cairo's default points, so that width="1024" means 1024 px.
  cairo_svg_surface_set_document_unit(surface.get(), CAIRO_SVG_UNIT_PX);
  {
    Context cr(cairo_create(surface.get()));
    draw(view, options, cr.get());
    check(cairo_status(cr.get()), "writeSvg", path);
  }
  cairo_surface_finish(surface.get());
  check(cairo_surface_status(surface.get()), "writeSvg", path);
}

template <typename S>
void writePng(const HierarchyView<S>& view, const std::string& path, const ImageOptions& options) {
  checkOptions(options);
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, options.width, options.height));
  check(cairo_surface_status(surface.get()), "writePng", path);
  {
    Context cr(cairo_create(surface.get()));
    draw(view, options, cr.get());
    check(cairo_status(cr.get()), "writePng", path);
  }
  cairo_surface_flush(surface.get());
  check(cairo_surface_write_to_png(surface.get(), path.c_str()), "writePng", path);
}

template void writeSvg<float>(const HierarchyView<float>&, const std::string&, const ImageOptions&);
template void writeSvg<double>(const HierarchyView<double>&, const std::string&,
                               const ImageOptions&);
template void writePng<float>(const HierarchyView<float>&, const std::string&, const ImageOptions&);
template void writePng<double>(const HierarchyView<double>&, const std::string&,
                               const ImageOptions&);

}  // namespace cube
