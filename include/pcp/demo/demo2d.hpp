// The paper's demonstration in the plane ("Intuition and Advantages", the figure of predicted
// queries): a local SDF prior F is learned on a circle, and a query network Q is then trained for
// a square on that frozen prior. Each query q_g near the square is moved by Q to a q_l' in the
// circle's frame where F gives the signed distance and the direction that pull q_g onto the square;
// queries on the square land on the circle. The run uses the library's own networks and steps
// (pcp/nn) with points of dimension 2 -- no separate 2D code -- and draws the figure as PNG
// (pcp/render's writer). `pcp_demo2d -o DIR` is the example program.
//
// Stage 1 (METHOD.md §3-4, eq. 2): the encoder reads the circle's samples (one region), F is
// trained by the pulling loss on Gaussian queries around them (sigma = distance to the 50th
// neighbour, as in METHOD.md §1) plus a few uniform ones. Stage 2 (eq. 3-5): F and the circle's
// condition f stay frozen; Q maps q_g to q_l' = q_g + dq and is trained by the pulling loss at the
// square's queries. By default F's condition is the circle's own f (Stage2Config's Given
// condition: the figure's setting, where F *is* the circle's SDF); `predict_condition` runs the
// full method instead, Q predicting f' as well.
#pragma once

#include "pcp/core/progress.hpp"
#include "pcp/render/render.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace pcp::demo {

struct Demo2dOptions {
    double circle_radius = 0.5;      ///< the prior's shape: a circle of this radius at the origin
    double square_half_side = 0.45;  ///< the target: an axis-aligned square of this half side at the origin
    double extent = 1.0;             ///< the domain is [-extent, extent]^2 (both shapes inside it)
    int points = 512;                ///< samples on each shape, uniform in arc length
    int queries_per_point = 40;      ///< Gaussian queries around each sample (METHOD.md §1)
    int sigma_neighbour = 50;        ///< sigma of a sample = distance to this neighbour
    double uniform_fraction = 0.1;   ///< extra queries uniform in the domain, as a fraction of the Gaussian ones
    int width = 64;                  ///< H of F and Q
    int depth = 3;                   ///< L of F and Q
    int cond = 16;                   ///< C, the condition size
    int pool_width = 64;             ///< the encoder's per-point width
    int prior_steps = 2000;          ///< stage-1 steps (F and the encoder on the circle)
    int fit_steps = 2000;            ///< stage-2 steps (Q on the square)
    int batch = 512;                 ///< queries per step
    double lr = 1e-3;                ///< Adam's rate, cosine-decayed to 5 % of it
    bool predict_condition = false;  ///< Q also predicts f' (the full method) instead of using the circle's f
    std::uint64_t seed = 1;
    int grid = 256;                  ///< marching-squares cells per side for F_g's zero set
};

/// What a run produced, in the domain's coordinates (2 x N matrices).
struct Demo2dResult {
    Eigen::Matrix2Xd circle;              ///< samples on the circle (the prior's data)
    Eigen::Matrix2Xd square;              ///< samples on the square (the query network's data)
    Eigen::Matrix2Xd queries;             ///< q_g: the square's Gaussian queries (up to 4000, for the figure)
    Eigen::Matrix2Xd predicted;           ///< q_l' = Q's point for each of `queries`
    Eigen::Matrix2Xd square_predicted;    ///< q_l' for the square's own samples
    std::vector<std::array<Eigen::Vector2d, 2>> zero_set;  ///< segments of F_g = 0 (marching squares)
    Eigen::MatrixXd field;                ///< F_g at the (grid + 1)^2 nodes, field(i, j) at x_i, y_j, after
                                          ///< repair_sign_2d (as the 3D pipeline's fine repair)
    int sign_repaired_regions = 0;        ///< regions repair_sign_2d flipped (0 where F_g's sign was right)
    Eigen::MatrixXd prior_field;          ///< F(q, f_circle) at the same nodes
    double prior_loss = 0;                ///< mean pulling loss of the last 10 % of stage-1 steps
    double fit_loss = 0;                  ///< the same for stage 2
    double prior_seconds = 0, fit_seconds = 0;
    bool cancelled = false;               ///< the progress callback asked to stop (nothing else is set)

    // Measurements (distances in the domain's units).
    double zero_set_max_distance = 0;     ///< largest distance of a zero-set vertex to the square
    double zero_set_mean_distance = 0;    ///< mean of the same
    double square_max_gap = 0;            ///< largest distance of a square sample to the zero set
    double predicted_radius_median = 0;   ///< median | |q_l'| - r | over the square's samples
    double predicted_radius_p90 = 0;      ///< its 90th percentile
};

/// The plane's counterpart of the 3D pipeline's fine sign repair (include/pcp/mesh/repair/fine_repair.hpp):
/// a region of one sign of `field` (4-connected nodes; field(i, j) at x_i, y_j of `o`'s grid) that
/// has no node within `near` of a data point and does not reach the domain's border is negated. The
/// pulling loss cannot tell a field from its negation where no query constrains it: on some seeds
/// and roundings F_g grows a positive pocket in the middle of the square, far from every sample.
/// Returns how many regions were negated.
int repair_sign_2d(Eigen::MatrixXd& field, const Eigen::Matrix2Xd& data, double near, const Demo2dOptions& o);

/// Runs both stages and measures the result (a few seconds on 2 cores with the defaults).
/// @throws pcp::Error for options out of range (naming the option), or when `progress` cancels.
Demo2dResult run_demo2d(const Demo2dOptions& options = {}, const ProgressCallback& progress = {});

/// The figure's panels, each `size` pixels square: (a) the prior F on the circle (level sets, zero
/// set in black, the circle's samples); (b) the square's queries q_g coloured by their angle around
/// the centre; (c) their predicted q_l' in the circle's frame with the same colours, on the circle;
/// (d) F_g's zero set against the square. Returned as one image, the panels side by side.
Image draw_demo2d_figure(const Demo2dResult& result, const Demo2dOptions& options, int size = 480);

/// Writes figure.png (all four panels) and prior.png, queries.png, predicted.png, zero_set.png
/// into `dir` (which must exist); returns the paths written.
/// @throws pcp::Error naming the file when a write fails.
std::vector<std::string> write_demo2d_pictures(const Demo2dResult& result, const Demo2dOptions& options,
                                               const std::string& dir, int size = 480);

/// Distance from p to the boundary of the axis-aligned square of half side h at the origin.
double distance_to_square(const Eigen::Vector2d& p, double h);

}  // namespace pcp::demo
