// Conservative advancement around coal's convex distance: the honest compiled competitor
// of DESIGN §9 ("Against the honest compiled competitor").
//
// For each track (rational motion, one convex body part, one convex obstacle part):
//   t = t_start; loop { d = distance(body at pose(t), obstacle);
//                       d < 0 -> collision; d < tol -> the proof ends at t (toi_lo);
//                       t += max(d, tol) / V }
// with V a proven speed bound (RationalMotion.speed_bound, per knot interval, for points
// within the body's bounding radius of the body origin) taken as the largest V of the
// knot intervals that the step can reach, so that no body point can cover the distance
// d within the step. This is the rule of harness' `lipschitz` bound. A pose within `tol`
// ends the proof but not the search: the track goes on with steps of tol / V and can
// still find an intersecting pose.
//
// Poses come from the motion's Bézier control matrices (weight last, DESIGN §1):
//   M_h(t) = sum_i B_i^n(u) C[s, i],  u = (t - breaks[s]) / (breaks[s+1] - breaks[s]),
//   R = M_h[:3, :3] / M_h[3, 3],  p = M_h[:3, 3] / M_h[3, 3].
//
// coal's GJK stops at a relative duality gap of `gjk_tolerance` (1e-6 by default), so the
// distance it returns may exceed the true one by that fraction: steps use
// d_lo = d - gjk_tolerance * |d|. Closed-form pairs (sphere/capsule) are exact anyway.
//
// CPU time is measured here with clock_gettime(CLOCK_PROCESS_CPUTIME_ID) around the loop
// over all tracks (pose evaluation, distance calls and stepping; no Python).

#include <coal/collision_data.h>
#include <coal/distance.h>
#include <coal/shape/geometric_shapes.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <limits>
#include <memory>
#include <vector>

namespace {

enum Kind { BOX = 0, SPHERE = 1, CAPSULE = 2 };
enum Verdict { FREE = 0, COLLISION = 1, UNKNOWN = 2 };
enum Reason { CLEAR = 0, CONTACT = 1, TOLERANCE = 2, BUDGET = 3 };

double cpu_now() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// A shape record: kind, size (box: half extents; sphere: radius; capsule: radius,
// half length), centre (3) and rotation (3x3, row major) in its own frame.
std::shared_ptr<coal::CollisionGeometry> make_shape(int kind, const double* rec) {
  const double* size = rec;
  switch (kind) {
    case BOX:
      return std::make_shared<coal::Box>(2 * size[0], 2 * size[1], 2 * size[2]);
    case SPHERE:
      return std::make_shared<coal::Sphere>(size[0]);
    case CAPSULE:
      return std::make_shared<coal::Capsule>(size[0], 2 * size[1]);
    default:
      return nullptr;
  }
}

coal::Transform3s shape_frame(const double* rec) {
  coal::Matrix3s r;
  r << rec[6], rec[7], rec[8], rec[9], rec[10], rec[11], rec[12], rec[13], rec[14];
  return coal::Transform3s(r, coal::Vec3s(rec[3], rec[4], rec[5]));
}

struct Motion {
  int segments, degree;
  const double* breaks;  // (S+1,)
  const double* ctrl;    // (S, n+1, 4, 4)
  int n_iv;
  const double* knots;   // (K,)
  const double* speed;   // (K-1,)
};

// Bernstein basis B_i^n(u), i = 0..n, with positive terms only.
void bernstein(int n, double u, double* b) {
  double v = 1.0 - u;
  double up[32], vp[32];
  up[0] = vp[0] = 1.0;
  for (int i = 1; i <= n; ++i) {
    up[i] = up[i - 1] * u;
    vp[i] = vp[i - 1] * v;
  }
  double binom = 1.0;
  for (int i = 0; i <= n; ++i) {
    b[i] = binom * up[i] * vp[n - i];
    binom = binom * (n - i) / (i + 1);
  }
}

// Pose at t on segment s (the caller keeps s current).
coal::Transform3s pose(const Motion& m, int s, double t) {
  const double a = m.breaks[s], h = m.breaks[s + 1] - a;
  double u = (t - a) / h;
  u = std::min(1.0, std::max(0.0, u));
  const int n = m.degree;
  double b[32];
  bernstein(n, u, b);
  const double* c = m.ctrl + static_cast<size_t>(s) * (n + 1) * 16;
  double mh[16] = {0};
  for (int i = 0; i <= n; ++i) {
    const double* ci = c + 16 * i;
    for (int k = 0; k < 12; ++k) mh[k] += b[i] * ci[k];
    mh[15] += b[i] * ci[15];
  }
  const double iw = 1.0 / mh[15];
  coal::Matrix3s r;
  r << mh[0] * iw, mh[1] * iw, mh[2] * iw, mh[4] * iw, mh[5] * iw, mh[6] * iw, mh[8] * iw,
      mh[9] * iw, mh[10] * iw;
  return coal::Transform3s(r, coal::Vec3s(mh[3] * iw, mh[7] * iw, mh[11] * iw));
}

}  // namespace

extern "C" {

// Runs every track; returns 0, or -(1 + track) for a track with an unknown shape kind.
//
// In (per track i): motion index mot[i] into the motion tables; body_kind[i] and
// body_rec[i*15 .. +15] (size 3, centre 3, rotation 9) in body coordinates;
// obst_kind[i], obst_rec[i*15 ..] in world coordinates.
// Motion tables (per motion j): seg[j], deg[j], breaks_off[j], ctrl_off[j], n_iv[j],
// knots_off[j], speed_off[j] (offsets into breaks (S+1 each), ctrl ((S, n+1, 4, 4) each),
// knots (n_iv + 1 each) and speed (n_iv each)).
// Out (per track): verdict (0 free, 1 collision, 2 unknown), reason (0 clear, 1 contact,
// 2 tolerance, 3 budget), toi_lo, toi_hi, calls; cpu_seconds[0] the CPU time of the loop.
int ca_run(int n_tracks, const int* mot, const int* body_kind, const double* body_rec,
           const int* obst_kind, const double* obst_rec, const int* seg, const int* deg,
           const long* breaks_off, const long* ctrl_off, const int* n_iv, const long* knots_off,
           const long* speed_off,
           const double* breaks, const double* ctrl, const double* knots,
           const double* speed, double tol, long max_calls, int warm_start,
           int* verdict_out, int* reason_out, double* toi_lo_out, double* toi_hi_out,
           long* calls_out, double* cpu_seconds_out) {
  const double inf = std::numeric_limits<double>::infinity();
  const double start = cpu_now();
  for (int i = 0; i < n_tracks; ++i) {
    const int j = mot[i];
    Motion m{seg[j],         deg[j], breaks + breaks_off[j], ctrl + ctrl_off[j],
             n_iv[j],        knots + knots_off[j],           speed + speed_off[j]};
    auto body = make_shape(body_kind[i], body_rec + 15 * i);
    auto obst = make_shape(obst_kind[i], obst_rec + 15 * i);
    if (!body || !obst) return -(1 + i);
    const coal::Transform3s body_local = shape_frame(body_rec + 15 * i);
    const coal::Transform3s obst_tf = shape_frame(obst_rec + 15 * i);
    coal::ComputeDistance dist(body.get(), obst.get());
    coal::DistanceRequest req;
    req.enable_signed_distance = true;
    if (warm_start) req.gjk_initial_guess = coal::GJKInitialGuess::CachedGuess;
    const double gjk_rel = req.gjk_tolerance;
    coal::DistanceResult res;

    const double t_end = m.breaks[m.segments];
    double t = m.breaks[0];
    double first_near = inf;
    int s = 0, k = 0;  // current Bézier segment and knot interval
    long calls = 0;
    int verdict = FREE, reason = CLEAR;
    double toi_hi = inf;
    while (true) {
      while (s < m.segments - 1 && t >= m.breaks[s + 1]) ++s;
      res.clear();
      const coal::Transform3s tf = pose(m, s, t) * body_local;
      const double d = dist(tf, obst_tf, req, res);
      if (warm_start) req.updateGuess(res);
      ++calls;
      if (d < 0) {
        verdict = COLLISION;
        reason = CONTACT;
        toi_hi = t;
        break;
      }
      const double d_lo = d - gjk_rel * std::abs(d);
      if (d_lo < tol && first_near == inf) first_near = t;
      // largest speed bound over the knot intervals the step can reach
      while (k < m.n_iv - 1 && t >= m.knots[k + 1]) ++k;
      const double gap = first_near < inf ? std::max(d_lo, tol) : std::max(d_lo, 0.0);
      double v = m.speed[k];
      double reach = v > 0 ? t + gap / v : inf;
      int e = k;
      while (e < m.n_iv - 1 && reach > m.knots[e + 1]) {
        ++e;
        v = std::max(v, m.speed[e]);
      }
      if (v > 0) {
        t += gap / v;
      } else {  // no motion on the window: jump to its end
        t = m.knots[e + 1];
      }
      if (t >= t_end) break;
      if (calls >= max_calls) {
        verdict = UNKNOWN;
        reason = first_near < inf ? TOLERANCE : BUDGET;
        break;
      }
    }
    if (verdict == FREE && first_near < inf) {
      verdict = UNKNOWN;
      reason = TOLERANCE;
    }
    verdict_out[i] = verdict;
    reason_out[i] = reason;
    toi_hi_out[i] = toi_hi;
    // the earliest time not proven free: the first near pose, else the contact, else
    // where the budget stopped the track
    double lo = verdict == FREE ? inf : std::min(first_near, toi_hi);
    if (reason == BUDGET) lo = std::min(lo, t);
    toi_lo_out[i] = lo;
    calls_out[i] = calls;
  }
  cpu_seconds_out[0] = cpu_now() - start;
  return 0;
}

// Per-call cost of the distance alone: `calls` calls on fixed poses cycling through
// `n_poses` body transforms (rec layout as above, rotation row major), for a body and an
// obstacle record. Returns the CPU seconds.
double ca_distance_cost(int body_kind, const double* body_rec, int obst_kind,
                        const double* obst_rec, int n_poses, const double* poses, long calls,
                        int warm_start, double* checksum) {
  auto body = make_shape(body_kind, body_rec);
  auto obst = make_shape(obst_kind, obst_rec);
  if (!body || !obst) return -1.0;
  const coal::Transform3s body_local = shape_frame(body_rec);
  const coal::Transform3s obst_tf = shape_frame(obst_rec);
  std::vector<coal::Transform3s> tfs;
  for (int p = 0; p < n_poses; ++p) tfs.push_back(shape_frame(poses + 15 * p) * body_local);
  coal::ComputeDistance dist(body.get(), obst.get());
  coal::DistanceRequest req;
  if (warm_start) req.gjk_initial_guess = coal::GJKInitialGuess::CachedGuess;
  coal::DistanceResult res;
  double sum = 0.0;
  const double start = cpu_now();
  for (long c = 0; c < calls; ++c) {
    res.clear();
    sum += dist(tfs[c % n_poses], obst_tf, req, res);
    if (warm_start) req.updateGuess(res);
  }
  const double secs = cpu_now() - start;
  checksum[0] = sum;
  return secs;
}
}
