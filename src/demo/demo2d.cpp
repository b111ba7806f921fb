// The plane demonstration (see pcp/demo/demo2d.hpp): samples and queries in 2D, stage 1 on the
// circle and stage 2 on the square with the library's networks (dimension 2), F_g's zero set by
// marching squares, and the figure.
#include "pcp/demo/demo2d.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/nn/steps.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace pcp::demo {

namespace {

constexpr double kPi = 3.14159265358979323846;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

void check_options(const Demo2dOptions& o) {
    PCP_CHECK(o.circle_radius > 0 && o.circle_radius < o.extent, "demo2d: circle_radius must be in (0, extent)");
    PCP_CHECK(o.square_half_side > 0 && o.square_half_side * std::sqrt(2.0) < o.extent,
              "demo2d: the square (half side " << o.square_half_side << ") must fit inside the domain of extent "
                                               << o.extent);
    PCP_CHECK(o.points >= 16 && o.points <= 100000, "demo2d: points must be in [16, 100000]");
    PCP_CHECK(o.queries_per_point >= 1 && o.queries_per_point <= 1000, "demo2d: queries_per_point must be in [1, 1000]");
    PCP_CHECK(o.sigma_neighbour >= 1 && o.sigma_neighbour < o.points, "demo2d: sigma_neighbour must be in [1, points)");
    PCP_CHECK(o.uniform_fraction >= 0 && o.uniform_fraction <= 10, "demo2d: uniform_fraction must be in [0, 10]");
    PCP_CHECK(o.width >= 4 && o.width <= 1024 && o.depth >= 1 && o.depth <= 16 && o.cond >= 1 && o.cond <= 1024 &&
                  o.pool_width >= 4 && o.pool_width <= 4096,
              "demo2d: network sizes out of range (width 4-1024, depth 1-16, cond 1-1024, pool_width 4-4096)");
    PCP_CHECK(o.prior_steps >= 1 && o.fit_steps >= 1 && o.batch >= 8 && o.batch <= 65536,
              "demo2d: prior_steps and fit_steps must be positive and batch in [8, 65536]");
    PCP_CHECK(o.lr > 0 && o.lr < 1, "demo2d: lr must be in (0, 1)");
    PCP_CHECK(o.grid >= 8 && o.grid <= 4096, "demo2d: grid must be in [8, 4096]");
}

/// `n` samples uniform in arc length on the circle of radius r.
Eigen::Matrix2Xd sample_circle(int n, double r) {
    Eigen::Matrix2Xd p(2, n);
    for (int i = 0; i < n; ++i) {
        const double a = 2 * kPi * (i + 0.5) / n;
        p.col(i) << r * std::cos(a), r * std::sin(a);
    }
    return p;
}

/// `n` samples uniform in arc length on the square of half side h (counter-clockwise from (h, -h)).
Eigen::Matrix2Xd sample_square(int n, double h) {
    Eigen::Matrix2Xd p(2, n);
    const double side = 2 * h;
    for (int i = 0; i < n; ++i) {
        const double s = 4 * side * (i + 0.5) / n;  // arc length
        const int k = std::min(3, static_cast<int>(s / side));
        const double u = s - k * side - h;  // in [-h, h] along side k
        switch (k) {
            case 0: p.col(i) << h, u; break;
            case 1: p.col(i) << -u, h; break;
            case 2: p.col(i) << -h, -u; break;
            default: p.col(i) << u, -h; break;
        }
    }
    return p;
}

/// Index of the nearest column of `pts` to q (brute force: the demo's clouds are small).
Eigen::Index nearest(const Eigen::Matrix2Xd& pts, const Eigen::Vector2d& q) {
    Eigen::Index best = 0;
    (pts.colwise() - q).colwise().squaredNorm().minCoeff(&best);
    return best;
}

/// Queries and their targets (the nearest sample): Gaussian around each sample with sigma = the
/// distance to its k-th neighbour (METHOD.md §1), plus a uniform share over the domain.
void sample_queries(const Eigen::Matrix2Xd& pts, const Demo2dOptions& o, Rng& rng, Eigen::Matrix2Xd& q,
                    Eigen::Matrix2Xd& t) {
    const Eigen::Index n = pts.cols();
    const Eigen::Index gauss = n * o.queries_per_point;
    const Eigen::Index uniform = static_cast<Eigen::Index>(std::llround(o.uniform_fraction * double(gauss)));
    q.resize(2, gauss + uniform);
    t.resize(2, gauss + uniform);
    std::vector<double> d2(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = 0; j < n; ++j) d2[std::size_t(j)] = (pts.col(j) - pts.col(i)).squaredNorm();
        std::nth_element(d2.begin(), d2.begin() + o.sigma_neighbour, d2.end());
        const double sigma = std::sqrt(d2[std::size_t(o.sigma_neighbour)]);
        for (int k = 0; k < o.queries_per_point; ++k) {
            const Eigen::Index c = i * o.queries_per_point + k;
            q.col(c) << pts(0, i) + sigma * rng.normal(), pts(1, i) + sigma * rng.normal();
        }
    }
    for (Eigen::Index c = gauss; c < gauss + uniform; ++c)
        q.col(c) << o.extent * (2 * rng.uniform() - 1), o.extent * (2 * rng.uniform() - 1);
    for (Eigen::Index c = 0; c < q.cols(); ++c) t.col(c) = pts.col(nearest(pts, q.col(c)));
}

/// A batch of `b` pool columns drawn with replacement, as float matrices.
void draw_batch(const Eigen::Matrix2Xd& q, const Eigen::Matrix2Xd& t, int b, Rng& rng, nn::Mat<float>& qb,
                nn::Mat<float>& tb) {
    for (int c = 0; c < b; ++c) {
        const auto j = static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(q.cols())));
        qb.col(c) = q.col(j).cast<float>();
        tb.col(c) = t.col(j).cast<float>();
    }
}

nn::OptimOptions optim(const Demo2dOptions& o, int steps) {
    nn::OptimOptions opt;
    opt.lr.kind = nn::LrSchedule::Kind::Cosine;
    opt.lr.lr = o.lr;
    opt.lr.total_steps = steps;
    opt.lr.final_lr = 0.05 * o.lr;
    return opt;
}

/// Calls progress every 50 steps and at the end; false = cancel.
bool report(const ProgressCallback& progress, const char* stage, int step, int total, double loss,
            Clock::time_point t0) {
    if (!progress || (step % 50 != 0 && step != total)) return true;
    Progress p;
    p.stage = stage;
    p.step = step;
    p.total = total;
    p.loss = loss;
    p.has_loss = true;
    p.elapsed_s = seconds_since(t0);
    return progress(p);
}

/// The grid nodes x_i = -extent + 2 extent i / grid.
double node(const Demo2dOptions& o, int i) { return -o.extent + 2 * o.extent * i / o.grid; }

/// Marching squares on node values (field(i, j) at (x_i, y_j)): one or two segments per cell.
std::vector<std::array<Eigen::Vector2d, 2>> zero_segments(const Eigen::MatrixXd& f, const Demo2dOptions& o) {
    std::vector<std::array<Eigen::Vector2d, 2>> segs;
    for (int i = 0; i < o.grid; ++i)
        for (int j = 0; j < o.grid; ++j) {
            // Corners counter-clockwise: (i,j) (i+1,j) (i+1,j+1) (i,j+1); edge e joins corner e and e+1.
            const int ci[4] = {i, i + 1, i + 1, i};
            const int cj[4] = {j, j, j + 1, j + 1};
            double v[4];
            for (int k = 0; k < 4; ++k) v[k] = f(ci[k], cj[k]);
            Eigen::Vector2d cross[4];
            int m = 0;
            for (int e = 0; e < 4; ++e) {
                const int a = e, b = (e + 1) % 4;
                if ((v[a] < 0) == (v[b] < 0)) continue;
                const double s = v[a] / (v[a] - v[b]);
                const Eigen::Vector2d pa(node(o, ci[a]), node(o, cj[a])), pb(node(o, ci[b]), node(o, cj[b]));
                cross[m] = pa + s * (pb - pa);
                ++m;
            }
            if (m == 2) {
                segs.push_back({cross[0], cross[1]});
            } else if (m == 4) {
                // Saddle: the centre's sign (mean of the corners) decides which corners connect.
                const bool centre_neg = (v[0] + v[1] + v[2] + v[3]) < 0;
                const bool c0_neg = v[0] < 0;
                if (centre_neg == c0_neg) {  // corner 0 joins the centre: cut corners 1 and 3
                    segs.push_back({cross[0], cross[1]});
                    segs.push_back({cross[2], cross[3]});
                } else {  // cut corners 0 and 2
                    segs.push_back({cross[3], cross[0]});
                    segs.push_back({cross[1], cross[2]});
                }
            }
        }
    return segs;
}

double distance_to_segment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d ab = b - a;
    const double len2 = ab.squaredNorm();
    const double s = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    return (a + s * ab - p).norm();
}

double percentile(std::vector<double> v, double f) {
    if (v.empty()) return 0;
    const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(f * double(v.size() - 1) + 0.5));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

}  // namespace

double distance_to_square(const Eigen::Vector2d& p, double h) {
    const double dx = std::abs(p.x()) - h, dy = std::abs(p.y()) - h;
    if (dx > 0 || dy > 0) return std::hypot(std::max(dx, 0.0), std::max(dy, 0.0));
    return -std::max(dx, dy);  // inside: distance to the nearest side
}

int repair_sign_2d(Eigen::MatrixXd& field, const Eigen::Matrix2Xd& data, double near, const Demo2dOptions& o) {
    const int n = o.grid + 1;
    PCP_CHECK(field.rows() == n && field.cols() == n, "demo2d: the field must have (grid + 1)^2 nodes");
    PCP_CHECK(near >= 0, "demo2d: the near distance must be >= 0");
    const auto at = [n](int i, int j) { return std::size_t(i) * std::size_t(n) + std::size_t(j); };
    std::vector<char> is_near(std::size_t(n) * std::size_t(n), 0);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const Eigen::Vector2d x(node(o, i), node(o, j));
            is_near[at(i, j)] = (data.col(nearest(data, x)) - x).norm() <= near;
        }
    std::vector<char> seen(std::size_t(n) * std::size_t(n), 0);
    std::vector<std::pair<int, int>> stack, members;
    int flipped = 0;
    for (int i0 = 0; i0 < n; ++i0)
        for (int j0 = 0; j0 < n; ++j0) {
            if (seen[at(i0, j0)]) continue;
            const bool negative = field(i0, j0) < 0;
            bool keep = false;  // reaches the border or the data
            members.clear();
            stack.assign(1, {i0, j0});
            seen[at(i0, j0)] = 1;
            while (!stack.empty()) {
                const auto [i, j] = stack.back();
                stack.pop_back();
                members.push_back({i, j});
                if (i == 0 || j == 0 || i == n - 1 || j == n - 1 || is_near[at(i, j)]) keep = true;
                const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
                for (int d = 0; d < 4; ++d) {
                    const int a = i + di[d], b = j + dj[d];
                    if (a < 0 || b < 0 || a >= n || b >= n || seen[at(a, b)] || (field(a, b) < 0) != negative) continue;
                    seen[at(a, b)] = 1;
                    stack.push_back({a, b});
                }
            }
            if (keep) continue;
            for (const auto& [i, j] : members)
                field(i, j) = negative ? std::max(-field(i, j), 1e-12) : std::min(-field(i, j), -1e-12);
            ++flipped;
        }
    return flipped;
}

Demo2dResult run_demo2d(const Demo2dOptions& o, const ProgressCallback& progress) {
    check_options(o);
    Demo2dResult r;
    r.circle = sample_circle(o.points, o.circle_radius);
    r.square = sample_square(o.points, o.square_half_side);
    Rng rng(o.seed, 0x2d);

    // ---- Stage 1: F and the encoder on the circle (one region: the whole circle).
    const Clock::time_point t1 = Clock::now();
    Eigen::Matrix2Xd q1, t1q;
    sample_queries(r.circle, o, rng, q1, t1q);
    nn::PointNet<float> encoder(nn::pointnet_shape(o.cond, o.pool_width, o.pool_width, 2));
    nn::BranchMlp<float> decoder(nn::decoder_shape(o.cond, o.width, o.depth, 2));
    Rng init(o.seed, 0x2e);
    nn::init_pointnet(encoder, init);
    nn::init_decoder_geometric(decoder, init, o.circle_radius);
    nn::Stage1Trainer<float> prior(std::move(encoder), std::move(decoder), o.batch, o.points,
                                   optim(o, o.prior_steps));
    const nn::Mat<float> circle_f = r.circle.cast<float>();
    nn::Mat<float> qb(2, o.batch), tb(2, o.batch);
    double tail = 0;
    int tail_n = 0;
    const int tail_from1 = o.prior_steps - std::max(1, o.prior_steps / 10);
    for (int s = 0; s < o.prior_steps; ++s) {
        draw_batch(q1, t1q, o.batch, rng, qb, tb);
        const double L = prior.step(qb, tb, circle_f);
        if (s >= tail_from1) tail += L, ++tail_n;
        if (!report(progress, "prior", s + 1, o.prior_steps, L, t1)) {
            r.cancelled = true;
            return r;
        }
    }
    r.prior_loss = tail / std::max(1, tail_n);
    r.prior_seconds = seconds_since(t1);
    // The circle's condition f, frozen from here on.
    nn::PointNetCache<float> enc_cache(prior.encoder.shape, o.points, false);
    nn::pointnet_forward<float>(prior.encoder, circle_f, enc_cache);
    const nn::Mat<float> f_circle = enc_cache.f();

    // ---- Stage 2: Q on the square, F frozen.
    const Clock::time_point t2 = Clock::now();
    Eigen::Matrix2Xd q2, t2q;
    sample_queries(r.square, o, rng, q2, t2q);
    nn::Stage2Config config;
    config.condition = o.predict_condition ? nn::QueryCondition::Predicted : nn::QueryCondition::Given;
    nn::BranchMlp<float> Q(nn::stage2_query_shape(config, o.cond, o.width, o.depth, 0, 2));
    nn::init_query_net(Q, init);
    nn::Stage2Trainer<float> fit(std::move(Q), prior.decoder, o.batch, optim(o, o.fit_steps), config);
    const nn::Mat<float> no_codes;
    const nn::Mat<float> cond_batch = f_circle.replicate(1, o.batch);
    tail = 0;
    tail_n = 0;
    const int tail_from2 = o.fit_steps - std::max(1, o.fit_steps / 10);
    for (int s = 0; s < o.fit_steps; ++s) {
        draw_batch(q2, t2q, o.batch, rng, qb, tb);
        const double L = o.predict_condition ? fit.step(qb, tb, no_codes) : fit.step(qb, tb, no_codes, cond_batch);
        if (s >= tail_from2) tail += L, ++tail_n;
        if (!report(progress, "query-net", s + 1, o.fit_steps, L, t2)) {
            r.cancelled = true;
            return r;
        }
    }
    r.fit_loss = tail / std::max(1, tail_n);
    r.fit_seconds = seconds_since(t2);

    // ---- Evaluation: q_l' of queries and samples, F_g and F on the grid nodes.
    const int chunk = 4096;
    nn::GlobalSdfCache<float> cache(fit.query_net.shape, fit.decoder.shape, chunk);
    nn::BranchMlpCache<float> dec_cache(fit.decoder.shape, chunk, false);
    const nn::Mat<float> cond_chunk = f_circle.replicate(1, chunk);
    const nn::Mat<float> no_cond;
    // F_g (prior_only: F(., f_circle)) at the columns of `pts` into out, chunk by chunk, and q_l'
    // into moved (if not null).
    const auto eval = [&](const Eigen::Matrix2Xd& pts, Eigen::VectorXd& out, Eigen::Matrix2Xd* moved, bool prior_only) {
        out.resize(pts.cols());
        if (moved) moved->resize(2, pts.cols());
        for (Eigen::Index c0 = 0; c0 < pts.cols(); c0 += chunk) {
            const Eigen::Index n = std::min<Eigen::Index>(chunk, pts.cols() - c0);
            const nn::Mat<float> qf = pts.middleCols(c0, n).cast<float>();
            if (prior_only) {
                out.segment(c0, n) = nn::decoder_eval<float>(fit.decoder, qf, f_circle, dec_cache).transpose().cast<double>();
                continue;
            }
            const nn::CMatRef<float> cond = o.predict_condition ? nn::CMatRef<float>(no_cond) : nn::CMatRef<float>(cond_chunk.leftCols(n));
            const auto s = nn::global_sdf_eval<float>(fit.query_net, fit.decoder, qf, no_codes, cond, config, cache);
            out.segment(c0, n) = s.transpose().cast<double>();
            if (moved) moved->middleCols(c0, n) = cache.q_local.leftCols(n).cast<double>();
        }
    };
    Eigen::VectorXd values;
    // The figure's queries: every k-th of the square's Gaussian queries (up to 4000).
    const Eigen::Index gauss2 = Eigen::Index(o.points) * o.queries_per_point;
    const Eigen::Index stride = std::max<Eigen::Index>(1, (gauss2 + 3999) / 4000);
    r.queries.resize(2, (gauss2 + stride - 1) / stride);
    for (Eigen::Index c = 0; c < r.queries.cols(); ++c) r.queries.col(c) = q2.col(c * stride);
    eval(r.queries, values, &r.predicted, false);
    eval(r.square, values, &r.square_predicted, false);

    const int nodes = o.grid + 1;
    Eigen::Matrix2Xd grid_pts(2, Eigen::Index(nodes) * nodes);
    for (int i = 0; i < nodes; ++i)
        for (int j = 0; j < nodes; ++j) grid_pts.col(Eigen::Index(i) * nodes + j) << node(o, i), node(o, j);
    eval(grid_pts, values, nullptr, false);
    r.field = Eigen::Map<const Eigen::MatrixXd>(values.data(), nodes, nodes).transpose();  // (i, j)
    eval(grid_pts, values, nullptr, true);
    r.prior_field = Eigen::Map<const Eigen::MatrixXd>(values.data(), nodes, nodes).transpose();
    // Near the square: within 4 grid cells of a sample (about 4.5 sample spacings with the defaults).
    r.sign_repaired_regions = repair_sign_2d(r.field, r.square, 4 * 2 * o.extent / o.grid, o);
    r.zero_set = zero_segments(r.field, o);

    // ---- Measurements.
    double dmax = 0, dsum = 0;
    for (const auto& s : r.zero_set)
        for (const auto& p : s) {
            const double d = distance_to_square(p, o.square_half_side);
            dmax = std::max(dmax, d);
            dsum += d;
        }
    r.zero_set_max_distance = r.zero_set.empty() ? std::numeric_limits<double>::infinity() : dmax;
    r.zero_set_mean_distance = r.zero_set.empty() ? std::numeric_limits<double>::infinity() : dsum / (2.0 * r.zero_set.size());
    double gap = 0;
    for (Eigen::Index c = 0; c < r.square.cols(); ++c) {
        double best = std::numeric_limits<double>::infinity();
        for (const auto& s : r.zero_set) best = std::min(best, distance_to_segment(r.square.col(c), s[0], s[1]));
        gap = std::max(gap, best);
    }
    r.square_max_gap = gap;
    std::vector<double> radius_error(static_cast<std::size_t>(r.square_predicted.cols()));
    for (Eigen::Index c = 0; c < r.square_predicted.cols(); ++c)
        radius_error[std::size_t(c)] = std::abs(r.square_predicted.col(c).norm() - o.circle_radius);
    r.predicted_radius_median = percentile(radius_error, 0.5);
    r.predicted_radius_p90 = percentile(radius_error, 0.9);
    return r;
}

// ------------------------------------------------------------------------------------------------
// The figure
// ------------------------------------------------------------------------------------------------

namespace {

struct Canvas {
    Image image;
    int size = 0;
    double extent = 1;

    Canvas(int s, double e) : size(s), extent(e) {
        image.width = s;
        image.height = s;
        image.rgb.assign(std::size_t(s) * std::size_t(s) * 3, 255);
    }
    double px(double x) const { return (x + extent) / (2 * extent) * size; }
    double py(double y) const { return (extent - y) / (2 * extent) * size; }
    void put(int x, int y, const std::array<std::uint8_t, 3>& c) {
        if (x < 0 || y < 0 || x >= size || y >= size) return;
        std::uint8_t* p = image.pixel(x, y);
        p[0] = c[0], p[1] = c[1], p[2] = c[2];
    }
    void disc(double x, double y, double radius, const std::array<std::uint8_t, 3>& c) {
        const double cx = px(x), cy = py(y);
        const int r = static_cast<int>(std::ceil(radius));
        for (int dy = -r; dy <= r; ++dy)
            for (int dx = -r; dx <= r; ++dx)
                if (dx * dx + dy * dy <= radius * radius + 0.25)
                    put(static_cast<int>(std::floor(cx)) + dx, static_cast<int>(std::floor(cy)) + dy, c);
    }
    void line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double radius, const std::array<std::uint8_t, 3>& c) {
        const double len = std::hypot(px(b.x()) - px(a.x()), py(b.y()) - py(a.y()));
        const int n = std::max(1, static_cast<int>(std::ceil(2 * len)));
        for (int k = 0; k <= n; ++k) {
            const Eigen::Vector2d p = a + (b - a) * (double(k) / n);
            disc(p.x(), p.y(), radius, c);
        }
    }
};

const std::array<std::uint8_t, 3> kBlack{20, 20, 20};
const std::array<std::uint8_t, 3> kYellow{240, 190, 20};

/// A colour from the angle of p around the centre (the figure's colour code).
std::array<std::uint8_t, 3> angle_colour(const Eigen::Vector2d& p) {
    const double h = (std::atan2(p.y(), p.x()) + kPi) / (2 * kPi) * 6.0;  // [0, 6)
    const double x = 1 - std::abs(std::fmod(h, 2.0) - 1);
    double r = 0, g = 0, b = 0;
    switch (static_cast<int>(h) % 6) {
        case 0: r = 1, g = x; break;
        case 1: r = x, g = 1; break;
        case 2: g = 1, b = x; break;
        case 3: g = x, b = 1; break;
        case 4: r = x, b = 1; break;
        default: r = 1, b = x; break;
    }
    const auto c = [](double v) { return static_cast<std::uint8_t>(std::lround(30 + 200 * v)); };
    return {c(r), c(g), c(b)};
}

/// Background shaded by a field on the grid nodes: blue inside, warm outside, darker level lines
/// every 0.05.
void shade_field(Canvas& cv, const Eigen::MatrixXd& f, const Demo2dOptions& o) {
    const int g = o.grid;
    for (int y = 0; y < cv.size; ++y)
        for (int x = 0; x < cv.size; ++x) {
            const double wx = -o.extent + (x + 0.5) / cv.size * 2 * o.extent;
            const double wy = o.extent - (y + 0.5) / cv.size * 2 * o.extent;
            const double u = std::clamp((wx + o.extent) / (2 * o.extent) * g, 0.0, g - 1e-9);
            const double v = std::clamp((wy + o.extent) / (2 * o.extent) * g, 0.0, g - 1e-9);
            const int i = static_cast<int>(u), j = static_cast<int>(v);
            const double a = u - i, b = v - j;
            const double val = (1 - a) * (1 - b) * f(i, j) + a * (1 - b) * f(i + 1, j) + (1 - a) * b * f(i, j + 1) +
                               a * b * f(i + 1, j + 1);
            const double band = std::abs(std::fmod(std::abs(val), 0.05) - 0.025) / 0.025;  // 0 at a level line
            const double shade = band < 0.12 ? 0.86 : 1.0;
            std::array<std::uint8_t, 3> c = val < 0 ? std::array<std::uint8_t, 3>{200, 220, 245}
                                                    : std::array<std::uint8_t, 3>{250, 238, 222};
            for (auto& ch : c) ch = static_cast<std::uint8_t>(std::lround(ch * shade));
            cv.put(x, y, c);
        }
}

void draw_square(Canvas& cv, double h, double radius, const std::array<std::uint8_t, 3>& c) {
    const Eigen::Vector2d corners[4] = {{h, -h}, {h, h}, {-h, h}, {-h, -h}};
    for (int k = 0; k < 4; ++k) cv.line(corners[k], corners[(k + 1) % 4], radius, c);
}

void draw_circle(Canvas& cv, double r, double radius, const std::array<std::uint8_t, 3>& c) {
    const int n = 720;
    for (int k = 0; k < n; ++k) {
        const double a0 = 2 * kPi * k / n, a1 = 2 * kPi * (k + 1) / n;
        cv.line({r * std::cos(a0), r * std::sin(a0)}, {r * std::cos(a1), r * std::sin(a1)}, radius, c);
    }
}

void draw_zero_set(Canvas& cv, const std::vector<std::array<Eigen::Vector2d, 2>>& segs, double radius) {
    for (const auto& s : segs) cv.line(s[0], s[1], radius, kBlack);
}

Image panel(const Demo2dResult& r, const Demo2dOptions& o, int size, int which) {
    Canvas cv(size, o.extent);
    const int scale = std::max(1, size / 240);
    switch (which) {
        case 0: {  // the prior on the circle
            shade_field(cv, r.prior_field, o);
            draw_zero_set(cv, zero_segments(r.prior_field, o), 1.0);
            for (Eigen::Index c = 0; c < r.circle.cols(); c += 4) cv.disc(r.circle(0, c), r.circle(1, c), 1.5, kBlack);
            draw_text(cv.image, 6, 6, scale, "a  prior f on the circle");
            break;
        }
        case 1: {  // the square's queries, coloured by angle
            draw_square(cv, o.square_half_side, 2.5, kYellow);
            for (Eigen::Index c = 0; c < r.queries.cols(); ++c)
                cv.disc(r.queries(0, c), r.queries(1, c), 1.5, angle_colour(r.queries.col(c)));
            draw_text(cv.image, 6, 6, scale, "b  queries q_g at the square");
            break;
        }
        case 2: {  // their predictions in the circle's frame
            draw_circle(cv, o.circle_radius, 1.5, kBlack);
            for (Eigen::Index c = 0; c < r.predicted.cols(); ++c)
                cv.disc(r.predicted(0, c), r.predicted(1, c), 1.5, angle_colour(r.queries.col(c)));
            draw_text(cv.image, 6, 6, scale, "c  predicted q_l  same colours");
            break;
        }
        default: {  // F_g's zero set against the square
            shade_field(cv, r.field, o);
            draw_square(cv, o.square_half_side, 2.5, kYellow);
            draw_zero_set(cv, r.zero_set, 1.0);
            draw_text(cv.image, 6, 6, scale, "d  zero set of f_g  square");
            break;
        }
    }
    // A thin frame, so that panels side by side stay apart.
    for (int k = 0; k < size; ++k) {
        cv.put(k, 0, {170, 170, 170});
        cv.put(k, size - 1, {170, 170, 170});
        cv.put(0, k, {170, 170, 170});
        cv.put(size - 1, k, {170, 170, 170});
    }
    return cv.image;
}

}  // namespace

Image draw_demo2d_figure(const Demo2dResult& r, const Demo2dOptions& o, int size) {
    PCP_CHECK(size >= 64 && size <= 4096, "demo2d: the panel size must be in [64, 4096]");
    PCP_CHECK(!r.cancelled && r.field.rows() == o.grid + 1 && r.prior_field.rows() == o.grid + 1,
              "demo2d: the result does not belong to these options (or the run was cancelled)");
    Image fig;
    fig.width = 4 * size;
    fig.height = size;
    fig.rgb.assign(std::size_t(fig.width) * std::size_t(fig.height) * 3, 255);
    for (int k = 0; k < 4; ++k) {
        const Image p = panel(r, o, size, k);
        for (int y = 0; y < size; ++y)
            std::copy(p.pixel(0, y), p.pixel(0, y) + 3 * size, fig.pixel(k * size, y));
    }
    return fig;
}

std::vector<std::string> write_demo2d_pictures(const Demo2dResult& r, const Demo2dOptions& o, const std::string& dir,
                                               int size) {
    const Image fig = draw_demo2d_figure(r, o, size);
    std::vector<std::string> written;
    const std::string base = dir.empty() || dir.back() == '/' ? dir : dir + "/";
    write_png(base + "figure.png", fig);
    written.push_back(base + "figure.png");
    const char* names[4] = {"prior.png", "queries.png", "predicted.png", "zero_set.png"};
    for (int k = 0; k < 4; ++k) {
        write_png(base + names[k], panel(r, o, size, k));
        written.push_back(base + names[k]);
    }
    return written;
}

}  // namespace pcp::demo
