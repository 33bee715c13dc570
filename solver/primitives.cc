#include "solver/primitives.h"

#include <cmath>
#include <map>
#include <utility>

namespace shadowsg {

TriangleMesh MakeBox(const Eigen::Vector3d& h) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back((i & 1 ? 1 : -1) * h.x(), (i & 2 ? 1 : -1) * h.y(), (i & 4 ? 1 : -1) * h.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.faces.emplace_back(q[0], q[1], q[2]);
    m.faces.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}

TriangleMesh MakeIcosphere(double radius, int subdivisions) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  TriangleMesh m;
  m.vertices = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  m.faces = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
             {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (auto& v : m.vertices) v.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      m.vertices.push_back((m.vertices[a] + m.vertices[b]).normalized());
      return mid[key] = static_cast<int>(m.vertices.size()) - 1;
    };
    std::vector<Eigen::Vector3i> faces;
    for (const auto& f : m.faces) {
      const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      faces.insert(faces.end(), {{f[0], a, c}, {f[1], b, a}, {f[2], c, b}, {a, b, c}});
    }
    m.faces = std::move(faces);
  }
  for (auto& v : m.vertices) v *= radius;
  return m;
}

namespace {

// A surface of revolution around z from a profile of (r, z) points, bottom to
// top; profile ends with r = 0 are closed by the pole vertex itself.
TriangleMesh Revolve(const std::vector<std::pair<double, double>>& profile, int segments) {
  TriangleMesh m;
  std::vector<std::vector<int>> ring(profile.size());
  for (size_t i = 0; i < profile.size(); ++i) {
    const auto [r, z] = profile[i];
    if (r == 0) {
      m.vertices.emplace_back(0, 0, z);
      ring[i].assign(segments, static_cast<int>(m.vertices.size()) - 1);
      continue;
    }
    for (int s = 0; s < segments; ++s) {
      const double a = 2 * M_PI * s / segments;
      m.vertices.emplace_back(r * std::cos(a), r * std::sin(a), z);
      ring[i].push_back(static_cast<int>(m.vertices.size()) - 1);
    }
  }
  for (size_t i = 0; i + 1 < profile.size(); ++i)
    for (int s = 0; s < segments; ++s) {
      const int a = ring[i][s], b = ring[i][(s + 1) % segments];
      const int c = ring[i + 1][(s + 1) % segments], d = ring[i + 1][s];
      if (a != b) m.faces.emplace_back(a, b, c);
      if (c != d) m.faces.emplace_back(a, c, d);
    }
  return m;
}

}  // namespace

TriangleMesh MakeCylinder(double radius, double height, int segments) {
  return Revolve({{0, 0}, {radius, 0}, {radius, height}, {0, height}}, segments);
}

TriangleMesh MakeCone(double radius, double height, int segments) {
  return Revolve({{0, 0}, {radius, 0}, {0, height}}, segments);
}

TriangleMesh MakeTorus(double R, double r, int major_segments, int minor_segments) {
  TriangleMesh m;
  for (int i = 0; i < major_segments; ++i) {
    const double u = 2 * M_PI * i / major_segments;
    for (int j = 0; j < minor_segments; ++j) {
      const double v = 2 * M_PI * j / minor_segments;
      m.vertices.emplace_back((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                              r * std::sin(v));
    }
  }
  auto idx = [&](int i, int j) { return (i % major_segments) * minor_segments + (j % minor_segments); };
  for (int i = 0; i < major_segments; ++i)
    for (int j = 0; j < minor_segments; ++j) {
      m.faces.emplace_back(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1));
      m.faces.emplace_back(idx(i, j), idx(i + 1, j + 1), idx(i, j + 1));
    }
  return m;
}

}  // namespace shadowsg
