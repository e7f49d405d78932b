#include "host/poses/detect.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>

namespace imuforge::poses {

namespace {

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  // atan2 of |a×b| and a·b: accurate at the small angles that matter here (acos loses them).
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

Eigen::Vector3d median_dir(const std::vector<Eigen::Vector3d>& d, std::size_t j0, std::size_t j1) {
  Eigen::Vector3d m;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> v;
    for (std::size_t j = j0; j < j1; ++j) v.push_back(d[j][c]);
    m[c] = percentile(v, 0.5);
  }
  return m.norm() > 0 ? Eigen::Vector3d(m.normalized()) : Eigen::Vector3d(d[j0]);
}

// A candidate pose before merging: a piece of one still run.
struct Piece {
  std::size_t begin, end;
  int run;
  std::string note;  // why it was split off, if it was
};

struct Item {  // a listed stretch before numbering
  std::size_t begin, end;
  std::string reason;
  int pose_slot = -1;  // index into the merged pose list
};

}  // namespace

Pose pose_over(const Recording& rec, std::size_t begin, std::size_t end) {
  Pose p;
  p.begin = begin;
  p.end = end;
  p.parts.emplace_back(begin, end);
  for (std::size_t k = begin; k < end; ++k) {
    p.acc += Eigen::Vector3d(rec.y[k][0], rec.y[k][1], rec.y[k][2]);
    p.gyro += Eigen::Vector3d(rec.y[k][3], rec.y[k][4], rec.y[k][5]);
  }
  p.samples = end - begin;
  if (p.samples > 0) {
    p.acc /= static_cast<double>(p.samples);
    p.gyro /= static_cast<double>(p.samples);
  }
  return p;
}

Detection detect_poses(const Recording& rec, const DetectOptions& o) {
  const std::size_t n = rec.y.size();
  const double fs = rec.rate_hz;
  if (!(fs > 0) || n < 3) throw PoseError("static-pose detection: recording without samples or rate");
  if (!(o.window_s > 0 && o.min_dwell_s > 0 && o.settle_s >= 0 && o.lead_s >= 0 && o.k_accel > 0 && o.k_gyro > 0 &&
        o.hand_rate_rad_s >= 0 && o.block_s > 0 && o.split_deg > 0 && o.settle_deg > 0 && o.merge_gap_s >= 0))
    throw PoseError("static-pose detection: options must be positive (window, dwell, k, block, angles)");
  auto samples_of = [&](double s) { return static_cast<std::size_t>(std::lround(s * fs)); };
  const std::size_t h = std::max<std::size_t>(1, samples_of(o.window_s / 2));

  // 1. Windowed mean and deviation per channel from prefix sums of centred values (conditioning).
  std::array<double, 6> centre{};
  for (const auto& y : rec.y)
    for (int c = 0; c < 6; ++c) centre[c] += y[c] / static_cast<double>(n);
  std::array<std::vector<double>, 6> s1, s2, sd;
  for (int c = 0; c < 6; ++c) {
    s1[c].assign(n + 1, 0.0);
    s2[c].assign(n + 1, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const double v = rec.y[i][c] - centre[c];
      s1[c][i + 1] = s1[c][i] + v;
      s2[c][i + 1] = s2[c][i] + v * v;
    }
  }
  auto span = [&](std::size_t i) { return std::make_pair(i > h ? i - h : 0, std::min(n, i + h + 1)); };
  auto wmean = [&](int c, std::size_t i) {
    const auto [a, b] = span(i);
    return (s1[c][b] - s1[c][a]) / static_cast<double>(b - a) + centre[c];
  };
  for (int c = 0; c < 6; ++c) {
    sd[c].resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto [a, b] = span(i);
      const double m = (s1[c][b] - s1[c][a]) / static_cast<double>(b - a);
      sd[c][i] = std::sqrt(std::max(0.0, (s2[c][b] - s2[c][a]) / static_cast<double>(b - a) - m * m));
    }
  }
  Detection d;
  std::array<double, 6> floor{};
  for (int c = 0; c < 6; ++c) {
    const double lsb = c < 3 ? rec.accel_lsb : rec.gyro_lsb;
    floor[c] = std::max({percentile(sd[c], 0.10), lsb / std::sqrt(12.0), 1e-12});
    (c < 3 ? d.accel_floor : d.gyro_floor)[c % 3] = floor[c];
  }

  // 2. Still tests.
  std::vector<char> acc_still(n);
  for (std::size_t i = 0; i < n; ++i) {
    double r2 = 0;
    for (int c = 0; c < 3; ++c) r2 += sd[c][i] * sd[c][i] / (floor[c] * floor[c]);
    double s2 = 0;
    for (int c = 0; c < 3; ++c) s2 += sd[c][i] * sd[c][i];
    acc_still[i] = std::sqrt(r2 / 3) < o.k_accel || std::sqrt(s2) < o.hand_accel_mps2;
  }
  const std::size_t stride = std::max<std::size_t>(1, h / 2);
  for (int c = 0; c < 3; ++c) {
    std::vector<double> v, all;
    for (std::size_t i = 0; i < n; i += stride) {
      all.push_back(wmean(3 + c, i));
      if (acc_still[i]) v.push_back(all.back());
    }
    d.gyro_bias[c] = percentile(v.empty() ? all : v, 0.5);
  }
  d.gyro_limit_rad_s = std::max(o.k_gyro * d.gyro_floor.norm(), o.hand_rate_rad_s);
  auto gyro_rms = [&](std::size_t i) {
    double s = 0;
    for (int c = 0; c < 3; ++c) {
      const double m = wmean(3 + c, i) - d.gyro_bias[c];
      s += m * m + sd[3 + c][i] * sd[3 + c][i];
    }
    return std::sqrt(s);
  };
  std::vector<char> still(n);
  for (std::size_t i = 0; i < n; ++i) still[i] = acc_still[i] && gyro_rms(i) < d.gyro_limit_rad_s;

  // 3-5. Runs -> settle margins -> attitude pieces -> dwell and clipping.
  const std::size_t settle = samples_of(o.settle_s), lead = samples_of(o.lead_s);
  const std::size_t block = std::max<std::size_t>(1, samples_of(o.block_s));
  const std::size_t min_len = std::max<std::size_t>(2, static_cast<std::size_t>(std::ceil(o.min_dwell_s * fs)));
  std::vector<Piece> pieces;
  std::vector<Item> items;
  int run = 0;
  for (std::size_t i = 0; i < n;) {
    if (!still[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < n && still[j]) ++j;
    // The window already keeps h samples off the motion on each side: the margins count from the motion.
    const std::size_t extra_settle = settle > h ? settle - h : 0, extra_lead = lead > h ? lead - h : 0;
    const std::size_t a = i > 0 ? std::min(j, i + extra_settle) : i;
    const std::size_t b = j < n ? (j - a > extra_lead ? j - extra_lead : a) : j;
    i = j;
    if (b <= a) continue;
    // Block directions.
    const std::size_t nb = std::max<std::size_t>(1, (b - a) / block);
    auto blk = [&](std::size_t k) { return std::make_pair(a + k * block, k + 1 == nb ? b : a + (k + 1) * block); };
    std::vector<Eigen::Vector3d> dir(nb);
    for (std::size_t k = 0; k < nb; ++k) {
      const auto [p, q] = blk(k);
      dir[k] = pose_over(rec, p, q).acc.normalized();
    }
    std::vector<std::pair<std::size_t, std::size_t>> ranges;  // block ranges
    std::vector<std::pair<std::size_t, std::size_t>> stack = {{0, nb}};
    while (!stack.empty()) {
      const auto [j0, j1] = stack.back();
      stack.pop_back();
      const Eigen::Vector3d m = median_dir(dir, j0, j1);
      double dev = 0;
      for (std::size_t k = j0; k < j1; ++k) dev = std::max(dev, angle_deg(dir[k], m));
      if (dev <= o.split_deg || j1 - j0 < 2) {
        ranges.emplace_back(j0, j1);
        continue;
      }
      std::size_t cut = j0 + 1;
      double step = -1;
      for (std::size_t k = j0 + 1; k < j1; ++k)
        if (angle_deg(dir[k - 1], dir[k]) > step) {
          step = angle_deg(dir[k - 1], dir[k]);
          cut = k;
        }
      stack.emplace_back(cut, j1);
      stack.emplace_back(j0, cut);
    }
    std::sort(ranges.begin(), ranges.end());
    for (std::size_t r = 0; r < ranges.size(); ++r) {
      auto [j0, j1] = ranges[r];
      const Eigen::Vector3d m = median_dir(dir, j0, j1);
      double head = 0, tail = 0;
      std::size_t k0 = j0, k1 = j1;
      while (k0 + 1 < k1 && angle_deg(dir[k0], m) > o.settle_deg) head = std::max(head, angle_deg(dir[k0++], m));
      while (k1 > k0 + 1 && angle_deg(dir[k1 - 1], m) > o.settle_deg) tail = std::max(tail, angle_deg(dir[--k1], m));
      char buf[128];
      if (k0 > j0) {
        std::snprintf(buf, sizeof buf, "settling: attitude up to %.2f deg from the pose's", head);
        items.push_back({blk(j0).first, blk(k0).first, buf});
      }
      const std::size_t p = blk(k0).first, q = blk(k1 - 1).second;
      std::string note;
      if (ranges.size() > 1 && r > 0) {
        std::snprintf(buf, sizeof buf, "split: attitude changed %.2f deg without motion",
                      angle_deg(median_dir(dir, ranges[r - 1].first, ranges[r - 1].second), m));
        note = buf;
      }
      bool clipped = false;
      for (std::size_t k = p; k < q && !rec.accel_clipped.empty(); ++k) clipped = clipped || rec.accel_clipped[k];
      if (clipped) items.push_back({p, q, "rejected: accelerometer clipped at full scale"});
      else pieces.push_back({p, q, run, note});  // the dwell is judged after merging (a pose broken by blips)
      if (k1 < j1) {
        std::snprintf(buf, sizeof buf, "settling: attitude up to %.2f deg from the pose's", tail);
        items.push_back({blk(k1).first, b, buf});
      }
    }
    ++run;
  }

  // 6. Merge bumped poses: pieces of different runs, close in time and attitude, form one group; the
  // minimum dwell applies to the group (a pose broken into short pieces by vibration blips is kept).
  struct Group {
    std::vector<std::size_t> idx;
    std::vector<std::pair<double, double>> how;  // per piece after the first: angle (deg), gap (s)
    Pose pose;
  };
  std::vector<Group> groups;
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const Piece& pc = pieces[k];
    Pose cur = pose_over(rec, pc.begin, pc.end);
    if (!groups.empty() && pieces[groups.back().idx.back()].run != pc.run) {
      Pose& prev = groups.back().pose;
      const double gap_s = static_cast<double>(pc.begin - prev.end) / fs;
      const double ang = angle_deg(prev.acc, cur.acc);
      if (gap_s <= o.merge_gap_s && ang <= o.split_deg) {
        const double w0 = static_cast<double>(prev.samples), w1 = static_cast<double>(cur.samples);
        prev.acc = (w0 * prev.acc + w1 * cur.acc) / (w0 + w1);
        prev.gyro = (w0 * prev.gyro + w1 * cur.gyro) / (w0 + w1);
        prev.samples += cur.samples;
        prev.end = cur.end;
        prev.parts.push_back(cur.parts.front());
        groups.back().idx.push_back(k);
        groups.back().how.emplace_back(ang, gap_s);
        continue;
      }
    }
    groups.push_back({{k}, {}, cur});
  }
  for (Group& gr : groups) {
    char buf[200];
    const Piece& first = pieces[gr.idx.front()];
    if (gr.pose.samples < min_len) {
      std::snprintf(buf, sizeof buf, "rejected: shorter than min dwell (%.2f s < %.2f s%s)",
                    static_cast<double>(gr.pose.samples) / fs, o.min_dwell_s,
                    gr.idx.size() > 1 ? ", pieces merged" : "");
      for (std::size_t k : gr.idx) {
        const Piece& pc = pieces[k];
        items.push_back({pc.begin, pc.end, pc.note.empty() ? std::string(buf) : pc.note + "; " + buf});
      }
      continue;
    }
    const int slot = static_cast<int>(d.poses.size());
    items.push_back({first.begin, first.end, first.note.empty() ? "pose" : "pose (" + first.note + ")", slot});
    for (std::size_t m = 1; m < gr.idx.size(); ++m) {
      const Piece& pc = pieces[gr.idx[m]];
      std::snprintf(buf, sizeof buf, "merged into pose %d: same attitude (%.2f deg) after %.2f s of motion", slot,
                    gr.how[m - 1].first, gr.how[m - 1].second);
      items.push_back({pc.begin, pc.end, buf, -1});
    }
    d.poses.push_back(std::move(gr.pose));
  }
  for (const Pose& p : d.poses) d.still_s += static_cast<double>(p.samples) / fs;

  // Stretches: the items in time order, the gaps between them as motion.
  std::sort(items.begin(), items.end(), [](const Item& x, const Item& y) { return x.begin < y.begin; });
  auto add = [&](std::size_t p, std::size_t q, const std::string& why, int pose) {
    if (q <= p) return;
    Stretch s;
    s.t_begin_s = rec.t_s[p];
    s.t_end_s = q < n ? rec.t_s[q] : rec.t_s[n - 1] + 1.0 / fs;
    s.acc = pose_over(rec, p, q).acc;
    s.pose = pose;
    s.reason = why;
    d.stretches.push_back(std::move(s));
  };
  auto moving = [&](std::size_t p, std::size_t q) {
    double peak = 0;
    for (std::size_t k = p; k < q; ++k)
      peak = std::max(peak, (Eigen::Vector3d(rec.y[k][3], rec.y[k][4], rec.y[k][5]) - d.gyro_bias).norm());
    char buf[96];
    std::snprintf(buf, sizeof buf, "moving or settling (peak rate %.3g rad/s)", peak);
    add(p, q, buf, -1);
  };
  std::size_t at = 0;
  for (const Item& it : items) {
    moving(at, it.begin);
    add(it.begin, it.end, it.reason, it.pose_slot);
    at = std::max(at, it.end);
  }
  moving(at, n);
  return d;
}

StillPart still_part(const Recording& rec, DetectOptions opt) {
  StillPart sp;
  sp.total = rec.y.size();
  if (rec.rate_hz > 0) opt.min_dwell_s = std::min(opt.min_dwell_s, 0.5 * static_cast<double>(rec.y.size()) / rec.rate_hz);
  const Detection d = detect_poses(rec, opt);
  if (d.poses.empty()) {
    std::string why = "nothing still";
    for (const Stretch& t : d.stretches)
      if (t.reason != "pose") {
        why = t.reason;
        break;
      }
    sp.reason = "rejected: no still part (" + why + ")";
    return sp;
  }
  std::size_t best = 0;
  for (std::size_t k = 1; k < d.poses.size(); ++k)
    if (d.poses[k].samples > d.poses[best].samples) best = k;
  sp.parts = d.poses[best].parts;
  sp.samples = d.poses[best].samples;
  char buf[160];
  if (d.poses.size() > 1) {
    std::snprintf(buf, sizeof buf, "attitude changed during the dwell: kept the longest of %zu poses (%zu of %zu samples)",
                  d.poses.size(), sp.samples, sp.total);
    sp.reason = buf;
  } else if (sp.samples < sp.total) {
    std::snprintf(buf, sizeof buf, "kept %zu of %zu samples (settling/motion dropped)", sp.samples, sp.total);
    sp.reason = buf;
  }
  return sp;
}

std::string explain_table(const Detection& d) {
  std::string s;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "static-pose detection: %zu poses, %.1f s still; noise floor accel [%.3g %.3g %.3g] m/s^2, gyro "
                "[%.3g %.3g %.3g] rad/s; still gyro below %.3g rad/s about bias [%.3g %.3g %.3g]\n",
                d.poses.size(), d.still_s, d.accel_floor[0], d.accel_floor[1], d.accel_floor[2], d.gyro_floor[0],
                d.gyro_floor[1], d.gyro_floor[2], d.gyro_limit_rad_s, d.gyro_bias[0], d.gyro_bias[1], d.gyro_bias[2]);
  s += buf;
  s += "  pose   start_s     end_s   dur_s   mean_ax   mean_ay   mean_az  verdict\n";
  for (const Stretch& t : d.stretches) {
    char idx[16];
    if (t.pose >= 0) std::snprintf(idx, sizeof idx, "%d", t.pose);
    else std::snprintf(idx, sizeof idx, "-");
    std::snprintf(buf, sizeof buf, "  %4s %9.2f %9.2f %7.2f %9.4f %9.4f %9.4f  %s\n", idx, t.t_begin_s, t.t_end_s,
                  t.t_end_s - t.t_begin_s, t.acc[0], t.acc[1], t.acc[2], t.reason.c_str());
    s += buf;
  }
  return s;
}

}  // namespace imuforge::poses
