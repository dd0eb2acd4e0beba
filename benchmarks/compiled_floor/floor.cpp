// What one right-hand-side evaluation of the fixed-base rig costs when the loop around
// Pinocchio is compiled: the rig's own arm model (URDF reduced to the active joints, the
// impact frame added as in campaign.robot), timed in C++ against the same library the
// Python bindings call. Printed as "name microseconds" lines for benchmarks/compiled_floor.py.
//
// usage: floor MODEL_FILE
// MODEL_FILE (written by benchmarks/compiled_floor.py from the rig's Pinocchio model):
//   line 1: nv gx gy gz; then per joint (all revolute about z): parent, the joint placement
//   (rotation row-major, translation), armature, mass, centre of mass, rotational inertia
//   about it (row-major); last line: impact frame's joint and placement.
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

using namespace pinocchio;

template <class F> double median_us(F f, int n) {
  std::vector<double> t;
  for (int r = 0; r < 7; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) f(i);
    auto t1 = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count() / n);
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

int main(int argc, char** argv) {
  if (argc != 2) { std::fprintf(stderr, "usage: floor MODEL_FILE\n"); return 2; }
  std::ifstream in(argv[1]);
  int nj; double g[3];
  in >> nj >> g[0] >> g[1] >> g[2];
  Model model;
  model.gravity.linear() << g[0], g[1], g[2];
  auto read_se3 = [&in]() {
    Eigen::Matrix3d R; Eigen::Vector3d p;
    for (int i = 0; i < 9; ++i) in >> R(i / 3, i % 3);
    for (int i = 0; i < 3; ++i) in >> p[i];
    return SE3(R, p);
  };
  for (int j = 0; j < nj; ++j) {
    int parent; in >> parent;
    SE3 M = read_se3();
    double arm, mass; Eigen::Vector3d c; Eigen::Matrix3d I;
    in >> arm >> mass;
    for (int i = 0; i < 3; ++i) in >> c[i];
    for (int i = 0; i < 9; ++i) in >> I(i / 3, i % 3);
    JointIndex jid = model.addJoint(parent, JointModelRZ(), M, "j" + std::to_string(j + 1));
    model.appendBodyToJoint(jid, Inertia(mass, c, I), SE3::Identity());
    model.armature[jid - 1] = arm;
  }
  int fj; in >> fj;
  SE3 Mf = read_se3();
  if (!in) { std::fprintf(stderr, "floor: cannot read %s\n", argv[1]); return 2; }
  const FrameIndex fid = model.addFrame(Frame("impact_point", fj, 0, Mf, OP_FRAME));
  Data data(model);
  const int nv = model.nv;
  Eigen::VectorXd q = Eigen::VectorXd::Constant(model.nq, 0.3), v = Eigen::VectorXd::Constant(nv, 0.1),
                  tau = Eigen::VectorXd::Constant(nv, 1.0), a = Eigen::VectorXd::Zero(nv);
  Data::Matrix6x J(6, nv);
  volatile double sink = 0;
  const int n = 200000;
  std::printf("nv %d\n", nv);
  std::printf("aba %.4f\n", median_us([&](int i) { q[0] = 0.3 + 1e-9 * i; aba(model, data, q, v, tau, Convention::WORLD); sink = sink + data.ddq[0]; }, n));
  std::printf("rnea %.4f\n", median_us([&](int i) { q[0] = 0.3 + 1e-9 * i; rnea(model, data, q, v, a); sink = sink + data.tau[0]; }, n));
  std::printf("frame_jacobian %.4f\n", median_us([&](int i) {
    q[0] = 0.3 + 1e-9 * i;
    computeFrameJacobian(model, data, q, fid, LOCAL_WORLD_ALIGNED, J);
    sink = sink + J(0, 0) + data.oMf[fid].translation()[0];
  }, n));
  return 0;
}
