// The PCL peer of `pmon bench` (issue #16): the part of the sensor checks a plain PCL program does.
// Per frame: transform the sweep into the ego frame (pcl::transformPointCloud), keep the obstacle height band
// (pcl::PassThrough on z), count the points per grid cell, and take the maximum count over the cells under each
// object box (the cells that overlap the box with positive area, the test pmon uses). Reads the frames that
// `pmon bench --export-peers DIR` writes (format in crates/bench/src/peers.rs), checks its per-box maxima against
// pmon's, and prints the median time per frame.
//
// Build: crates/bench/peers/build_pcl.sh (installs Debian's libpcl-dev, about 1.3 GB; opt-in, not in CI).
// Usage: pcl_grid_box_max CASE_DIR [ITERATIONS] -> one line `case=... median_us=... p99_us=... max_us=...
// agree=K/M`.
#include <pcl/common/transforms.h>
#include <pcl/filters/passthrough.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct Box {
  float cx, cy, cos, sin, half_length, half_width;
};

struct FrameDef {
  size_t sweep;
  float t[3];
  std::vector<Box> boxes;
  std::vector<uint32_t> expected;
};

template <typename T>
std::vector<T> read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() % sizeof(T) != 0) throw std::runtime_error(path + ": size is not a whole number of records");
  std::vector<T> out(bytes.size() / sizeof(T));
  if (!bytes.empty()) std::memcpy(out.data(), bytes.data(), bytes.size());
  return out;
}

float bits_to_float(const std::string& hex) {
  uint32_t u = static_cast<uint32_t>(std::stoul(hex, nullptr, 16));
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

// pmon's OrientedRect::overlaps_square, operation for operation (built with -ffp-contract=off: no fused
// multiply-adds, so each value has pmon's bits).
bool overlaps_square(const Box& r, float x, float y, float h) {
  float dx = x - r.cx;
  float dy = y - r.cy;
  float c = std::fabs(r.cos), s = std::fabs(r.sin);
  if (std::fabs(dx) >= h + r.half_length * c + r.half_width * s) return false;
  if (!(std::fabs(dy) < h + r.half_length * s + r.half_width * c)) return false;
  float du = dx * r.cos + dy * r.sin;
  float dv = -dx * r.sin + dy * r.cos;
  float hs = h * (c + s);
  return std::fabs(du) < r.half_length + hs && std::fabs(dv) < r.half_width + hs;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: pcl_grid_box_max CASE_DIR [ITERATIONS]\n";
    return 2;
  }
  const std::string dir = argv[1];
  const int iterations = argc > 2 ? std::max(1, std::atoi(argv[2])) : 300;
  std::ifstream meta(dir + "/case.txt");
  if (!meta) {
    std::cerr << "cannot read " << dir << "/case.txt\n";
    return 2;
  }
  std::string name;
  float cell = 0, inv_cell = 0, origin = 0, lo = 0, hi = 0;
  uint32_t n = 0;
  std::vector<std::string> sweep_files;
  std::vector<FrameDef> frames;
  try {
    std::string line;
    while (std::getline(meta, line)) {
      std::istringstream ls(line);
      std::string key;
      ls >> key;
      std::string a, b, c, d, e;
      if (key == "name") {
        ls >> name;
      } else if (key == "cell_size_m") {
        ls >> a >> b; cell = bits_to_float(b);
      } else if (key == "inv_cell") {
        ls >> a >> b; inv_cell = bits_to_float(b);
      } else if (key == "origin_m") {
        ls >> a >> b; origin = bits_to_float(b);
      } else if (key == "cells_per_side") {
        ls >> n;
      } else if (key == "band_lo_m") {
        ls >> a >> b; lo = bits_to_float(b);
      } else if (key == "band_hi_m") {
        ls >> a >> b; hi = bits_to_float(b);
      } else if (key == "sweep") {
        ls >> a; sweep_files.push_back(dir + "/" + a);
      } else if (key == "frame") {
        FrameDef f{};
        std::string boxes, expected, tx, ty, tz;
        ls >> f.sweep >> tx >> ty >> tz >> boxes >> expected;
        f.t[0] = bits_to_float(tx); f.t[1] = bits_to_float(ty); f.t[2] = bits_to_float(tz);
        auto raw = read_all<float>(dir + "/" + boxes);
        for (size_t i = 0; i + 6 <= raw.size(); i += 6)
          f.boxes.push_back(Box{raw[i], raw[i + 1], raw[i + 2], raw[i + 3], raw[i + 4], raw[i + 5]});
        f.expected = read_all<uint32_t>(dir + "/" + expected);
        frames.push_back(std::move(f));
      }
    }
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 2;
  }
  if (frames.empty() || n == 0) {
    std::cerr << dir << ": no frames\n";
    return 2;
  }
  // The sweeps as PCL clouds (not timed: a PCL pipeline receives its cloud as a pcl::PointCloud).
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> clouds;
  for (const auto& path : sweep_files) {
    auto xyz = read_all<float>(path);
    pcl::PointCloud<pcl::PointXYZ>::Ptr c(new pcl::PointCloud<pcl::PointXYZ>);
    c->resize(xyz.size() / 3);
    for (size_t i = 0; i < c->size(); ++i) (*c)[i] = pcl::PointXYZ(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    clouds.push_back(c);
  }
  for (const auto& f : frames)
    if (f.sweep >= clouds.size()) {
      std::cerr << "frame refers to a missing sweep\n";
      return 2;
    }

  pcl::PointCloud<pcl::PointXYZ>::Ptr ego(new pcl::PointCloud<pcl::PointXYZ>);
  pcl::PointCloud<pcl::PointXYZ> band;
  pcl::PassThrough<pcl::PointXYZ> pass;
  pass.setFilterFieldName("z");
  pass.setFilterLimits(lo, hi);
  std::vector<uint16_t> counts(static_cast<size_t>(n) * n);
  std::vector<uint32_t> maxima;
  const float half = 0.5f * cell;
  const float nf = static_cast<float>(n);

  auto run = [&](const FrameDef& f) {
    Eigen::Affine3f t = Eigen::Affine3f::Identity();
    t.translation() << f.t[0], f.t[1], f.t[2];
    pcl::transformPointCloud(*clouds[f.sweep], *ego, t);
    pass.setInputCloud(ego);
    pass.filter(band);  // keeps finite points with lo <= z <= hi
    std::fill(counts.begin(), counts.end(), 0);
    for (const auto& p : band) {
      float fx = (p.x - origin) * inv_cell;
      float fy = (p.y - origin) * inv_cell;
      if (fx >= 0.0f && fx < nf && fy >= 0.0f && fy < nf) {
        uint16_t& c = counts[static_cast<uint32_t>(fy) * n + static_cast<uint32_t>(fx)];
        if (c < 65535) ++c;
      }
    }
    maxima.clear();
    for (const auto& b : f.boxes) {
      float ex = b.half_length * std::fabs(b.cos) + b.half_width * std::fabs(b.sin);
      float ey = b.half_length * std::fabs(b.sin) + b.half_width * std::fabs(b.cos);
      // The cells around the box's bounds (one more on each side), clipped to the grid; the exact test decides.
      auto col = [&](float v) { return std::floor((v - origin) * inv_cell); };
      long x0 = std::max(0L, static_cast<long>(col(b.cx - ex)) - 1);
      long x1 = std::min(static_cast<long>(n) - 1, static_cast<long>(col(b.cx + ex)) + 1);
      long y0 = std::max(0L, static_cast<long>(col(b.cy - ey)) - 1);
      long y1 = std::min(static_cast<long>(n) - 1, static_cast<long>(col(b.cy + ey)) + 1);
      uint32_t m = 0;
      for (long iy = y0; iy <= y1; ++iy) {
        float cy = origin + (static_cast<float>(iy) + 0.5f) * cell;
        for (long ix = x0; ix <= x1; ++ix) {
          float cx = origin + (static_cast<float>(ix) + 0.5f) * cell;
          if (overlaps_square(b, cx, cy, half)) m = std::max<uint32_t>(m, counts[iy * n + ix]);
        }
      }
      maxima.push_back(m);
    }
  };

  // Agreement with pmon (its hit counts saturate at 255).
  size_t agree = 0, total = 0;
  for (const auto& f : frames) {
    run(f);
    for (size_t i = 0; i < f.boxes.size() && i < f.expected.size(); ++i) {
      ++total;
      if (std::min<uint32_t>(maxima[i], 255) == f.expected[i]) ++agree;
    }
    total += f.boxes.size() != f.expected.size() ? 1 : 0;
  }
  // Warm-up: one cycle; then timed iterations cycling through the frames, as `pmon bench` does.
  for (const auto& f : frames) run(f);
  std::vector<double> us;
  us.reserve(iterations);
  size_t points = 0;
  for (int i = 0; i < iterations; ++i) {
    const auto& f = frames[i % frames.size()];
    auto t0 = std::chrono::steady_clock::now();
    run(f);
    auto t1 = std::chrono::steady_clock::now();
    points += band.size();
    us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  std::sort(us.begin(), us.end());
  auto rank = [&](double q) {
    size_t i = static_cast<size_t>(std::ceil(q * us.size()));
    return us[std::min(us.size(), std::max<size_t>(i, 1)) - 1];
  };
  double median = us.size() % 2 ? us[us.size() / 2] : 0.5 * (us[us.size() / 2 - 1] + us[us.size() / 2]);
  std::printf("peer=pcl case=%s median_us=%.2f p99_us=%.2f max_us=%.2f samples=%zu agree=%zu/%zu\n", name.c_str(),
              median, rank(0.99), us.back(), us.size(), agree, total);
  std::fflush(stdout);
  (void)points;
  return agree == total ? 0 : 1;
}
