// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// g2o adapters: the kernel agrees with the core to the last bit; g2o's own numeric
// linearisation agrees with our analytic Jacobians; the planar bundle adjustment recovers the
// truth (noise-free) or lands within 3 sigma of it (noisy).
#include <g2o/core/block_solver.h>
#include <g2o/core/jacobian_workspace.h>
#include <g2o/core/optimization_algorithm_levenberg.h>
#include <g2o/core/sparse_optimizer.h>
#include <g2o/solvers/eigen/linear_solver_eigen.h>
#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <random>

#include "../common/numeric.h"
#include "../common/planar_ba.h"
#include "rvwo/g2o/barron_kernel.h"
#include "rvwo/g2o/edges.h"

namespace rvwo {
namespace {

using g2o_adapters::BarronRobustKernel;
using g2o_adapters::EdgePlanarPriorSE3;
using g2o_adapters::EdgeSE2Wheel;
using g2o_adapters::EdgeSE2XYZ;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(G2oBarronKernel, AgreesWithCoreToTheLastBit) {
  for (double alpha : {-kInf, -7.28, -2.0, 0.0, 0.37, 1.0, 2.0, kInf}) {
    BarronRobustKernel k(alpha, 0.8);
    const BarronKernel core(alpha, 0.8);
    for (double s : {0.0, 1e-7, 0.3, 2.0, 17.0, 300.0}) {
      g2o::Vector3 a;
      double b[3];
      k.robustify(s, a);
      core.evaluate(s, b);
      for (int i = 0; i < 3; ++i) EXPECT_EQ(a[i], b[i]) << alpha << " " << s;
    }
  }
}

// The Jacobian block an edge's linearizeOplus() left for vertex i (0 or 1).
template <typename Edge>
Eigen::MatrixXd J(Edge& e, int i) {
  if constexpr (Edge::kNrOfVertices == 1) {
    return Eigen::MatrixXd(e.template jacobianOplusXn<0>());
  } else {
    return i == 0 ? Eigen::MatrixXd(e.template jacobianOplusXn<0>()) : Eigen::MatrixXd(e.template jacobianOplusXn<1>());
  }
}

std::shared_ptr<g2o::VertexSE2> poseVertex(int id, const Eigen::Vector3d& x) {
  auto v = std::make_shared<g2o::VertexSE2>();
  v->setId(id);
  v->setEstimate(g2o::SE2(x.x(), x.y(), x.z()));
  return v;
}
std::shared_ptr<g2o::VertexPointXYZ> pointVertex(int id, const Eigen::Vector3d& p) {
  auto v = std::make_shared<g2o::VertexPointXYZ>();
  v->setId(id);
  v->setEstimate(p);
  return v;
}

TEST(G2oEdges, NumericLinearisationAgreesWithAnalytic) {
  const test::PlanarBA ba(false, 11);
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(-1, 1);
  const Se2XyzMonoEdge core = ba.edge();
  const Se2XyzStereoEdge stereo(ba.camera, ba.T_b_c, 54.0);
  using MonoBase = g2o::BaseFixedSizedEdge<2, Eigen::Vector2d, g2o::VertexSE2, g2o::VertexPointXYZ>;
  using StereoBase = g2o::BaseFixedSizedEdge<3, Eigen::Vector3d, g2o::VertexSE2, g2o::VertexPointXYZ>;
  using WheelBase = g2o::BaseFixedSizedEdge<3, Eigen::Vector3d, g2o::VertexSE2, g2o::VertexSE2>;
  // g2o points each edge's Jacobian blocks into a workspace it allocates before linearising.
  g2o::JacobianWorkspace ws;
  ws.updateSize(2, 3 * 3);
  ws.allocate();
  double worst = 0;
  int n = 0;
  for (const test::Observation& o : ba.observations) {
    if (n++ >= 300) break;
    auto v0 = poseVertex(0, ba.poses[o.pose] + 0.01 * test::drawVector<3>(u, rng));
    auto v1 = pointVertex(1, ba.points[o.point]);
    EdgeSE2XYZ<2> e(core);
    e.setVertex(0, v0);
    e.setVertex(1, v1);
    e.setMeasurement(o.z);
    e.linearizeOplus(ws);  // allocates the blocks, then our analytic linearizeOplus()
    const Eigen::MatrixXd Ai = J(e, 0), Aj = J(e, 1);
    e.MonoBase::linearizeOplus();  // g2o's numeric differentiation
    worst = std::max({worst, test::relativeError(Ai, J(e, 0)), test::relativeError(Aj, J(e, 1))});
    EdgeSE2XYZ<3> s(stereo);
    s.setVertex(0, v0);
    s.setVertex(1, v1);
    s.setMeasurement(Eigen::Vector3d::Zero());
    s.linearizeOplus(ws);
    const Eigen::MatrixXd Si = J(s, 0), Sj = J(s, 1);
    s.StereoBase::linearizeOplus();
    worst = std::max({worst, test::relativeError(Si, J(s, 0)), test::relativeError(Sj, J(s, 1))});
  }
  for (int k = 0; k + 1 < 6; ++k) {
    EdgeSE2Wheel w(ba.wheel[k]);
    w.setVertex(0, poseVertex(0, ba.poses[k] + Eigen::Vector3d(0.1, 0.2, -0.3)));
    w.setVertex(1, poseVertex(1, ba.poses[k + 1]));
    w.linearizeOplus(ws);
    const Eigen::MatrixXd Ai = J(w, 0), Aj = J(w, 1);
    w.WheelBase::linearizeOplus();
    worst = std::max({worst, test::relativeError(Ai, J(w, 0)), test::relativeError(Aj, J(w, 1))});
  }
  // g2o differentiates with a fixed step of 1e-9 and one-sided round-off ~1e-7 relative.
  EXPECT_LT(worst, 1e-5);
  std::cout << "g2o numeric vs analytic, worst relative difference: " << worst << "\n";
}

TEST(G2oEdges, PlanarPriorOnSE3ExpmapAgreesWithNumeric) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Isometry3d T_w_p = Eigen::Isometry3d::Identity();
  T_w_p.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  const PlanarPrior prior(T_w_p, 0.01, 0.02);
  const Eigen::Isometry3d T_b_c = test::forwardCamera();  // the vertex is a camera, as in ORB-SLAM3
  g2o::JacobianWorkspace ws;
  ws.updateSize(1, 3 * 6);
  ws.allocate();
  using PriorBase = g2o::BaseFixedSizedEdge<3, Eigen::Vector3d, g2o::VertexSE3Expmap>;
  double worst = 0;
  for (int i = 0; i < 200; ++i) {
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    const Eigen::Vector2d tilt = 0.2 * test::drawVector<2>(u, rng);
    T_w_b.linear() =
        Eigen::AngleAxisd(3 * u(rng), Eigen::Vector3d(tilt.x(), tilt.y(), 1).normalized()).toRotationMatrix();
    T_w_b.translation() << 5 * u(rng), 5 * u(rng), 0.3 * u(rng);
    auto v = std::make_shared<g2o::VertexSE3Expmap>();
    v->setId(0);
    const Eigen::Isometry3d T_c_w = (T_w_b * T_b_c).inverse();
    v->setEstimate(g2o::SE3Quat(T_c_w.linear(), T_c_w.translation()));
    EdgePlanarPriorSE3 e(prior, T_b_c);
    e.setVertex(0, v);
    e.computeError();
    EXPECT_LT((e.error() - prior.residual(T_w_b)).norm(), 1e-9);
    e.linearizeOplus(ws);
    const Eigen::MatrixXd A = J(e, 0);
    e.PriorBase::linearizeOplus();  // g2o's numeric differentiation through the vertex's own update
    worst = std::max(worst, test::relativeError(A, J(e, 0)));
  }
  EXPECT_LT(worst, 1e-5);
  std::cout << "planar prior on VertexSE3Expmap: numeric vs analytic " << worst << "\n";
}

struct G2oBA {
  std::vector<Eigen::Vector3d> x, p;
  G2oBA(const test::PlanarBA& ba, unsigned seed) {
    ba.perturbedStart(seed, &x, &p);
    g2o::SparseOptimizer opt;
    using Block = g2o::BlockSolverX;
    auto linear = std::make_unique<g2o::LinearSolverEigen<Block::PoseMatrixType>>();
    opt.setAlgorithm(std::make_shared<g2o::OptimizationAlgorithmLevenberg>(std::make_unique<Block>(std::move(linear))));
    std::vector<std::shared_ptr<g2o::VertexSE2>> vx;
    std::vector<std::shared_ptr<g2o::VertexPointXYZ>> vp;
    for (int k = 0; k < 6; ++k) {
      vx.push_back(poseVertex(k, x[k]));
      vx.back()->setFixed(k == 0);
      opt.addVertex(vx.back());
    }
    for (std::size_t i = 0; i < p.size(); ++i) {
      vp.push_back(pointVertex(static_cast<int>(100 + i), p[i]));
      vp.back()->setMarginalized(true);
      opt.addVertex(vp.back());
    }
    const Se2XyzMonoEdge core = ba.edge();
    for (const test::Observation& o : ba.observations) {
      auto e = std::make_shared<EdgeSE2XYZ<2>>(core);
      e->setVertex(0, vx[o.pose]);
      e->setVertex(1, vp[o.point]);
      e->setMeasurement(o.z);
      e->setInformation(o.sqrt_information.transpose() * o.sqrt_information);
      opt.addEdge(e);
    }
    for (int k = 0; k + 1 < 6; ++k) {
      auto e = std::make_shared<EdgeSE2Wheel>(ba.wheel[k]);
      e->setVertex(0, vx[k]);
      e->setVertex(1, vx[k + 1]);
      opt.addEdge(e);
    }
    opt.initializeOptimization();
    opt.optimize(100);
    for (int k = 0; k < 6; ++k) x[k] = vx[k]->estimate().toVector();
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = vp[i]->estimate();
  }
};

TEST(G2oPlanarBA, NoiseFreeRecoversTheTruth) {
  const test::PlanarBA ba(false, 7);
  const G2oBA s(ba, 8);
  double worst = 0;
  for (int k = 0; k < 6; ++k) worst = std::max(worst, (s.x[k] - ba.poses[k]).cwiseAbs().maxCoeff());
  for (std::size_t i = 0; i < ba.points.size(); ++i)
    worst = std::max(worst, (s.p[i] - ba.points[i]).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 1e-6);
}

TEST(G2oPlanarBA, NoisyWithinThreeSigma) {
  const test::PlanarBA ba(true, 9);
  const G2oBA s(ba, 10);
  const Eigen::MatrixXd cov = ba.poseCovariance(s.x, s.p);
  const Eigen::VectorXd err = ba.poseErrors(s.x);
  for (int i = 0; i < 15; ++i) EXPECT_LT(std::fabs(err(i)), 3 * std::sqrt(cov(i, i))) << "pose dof " << i;
  EXPECT_LT(err.dot(cov.ldlt().solve(err)), 37.7);
}

}  // namespace
}  // namespace rvwo
