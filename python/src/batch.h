#pragma once

// The Python Body of the batched checks (batch.cpp), shared with the benchmarks' module
// (python/benchmarks), which times the library's call on the same body.

#include <cube_collision/batch.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common.h"

namespace cubepy {

/// What the BodySet does not answer of a link: the Python geometry it was made from and its
/// filter bits (pickling). Its margin and the excluded pairs are read from the BodySet.
struct Link {
  GeometryPtr geometry;
  std::uint64_t category, mask;
};

/// The moving bodies: cube::BodySet plus what rebuilds it (pickling).
struct Body {
  cube::BodySet<double> set;
  std::vector<Link> links;

  std::size_t addLink(GeometryPtr g, double margin, std::uint64_t category, std::uint64_t mask) {
    if (g->kind == "plane" || g->kind == "halfspace")
      throw py::value_error("add_link: a link must be bounded (no plane or halfspace)");
    if (!std::isfinite(margin) || margin < 0)
      throw py::value_error("add_link: margin must be finite and >= 0");
    const std::size_t i = set.addLink(g->fcl, margin, category, mask);
    links.push_back({g, category, mask});
    return i;
  }
  std::vector<std::string> kinds() const {
    std::vector<std::string> out;
    for (const auto& l : links) out.push_back(l.geometry->kind);
    return out;
  }
  /// `where`: the Python call named in errors.
  void excludePair(std::size_t i, std::size_t j, const char* where) {
    if (i >= links.size() || j >= links.size() || i == j)
      throw py::value_error(std::string(where) + ": two different link indices below " +
                            std::to_string(links.size()) + " expected");
    set.excludePair(i, j);
  }
  /// The pairs of links never checked, (i, j) with i < j, sorted.
  std::vector<std::pair<std::size_t, std::size_t>> excluded() const {
    std::vector<std::pair<std::size_t, std::size_t>> out;
    for (std::size_t i = 0; i < links.size(); ++i)
      for (std::size_t j = i + 1; j < links.size(); ++j)
        if (!set.checked(i, j)) out.emplace_back(i, j);
    return out;
  }
};

}  // namespace cubepy
