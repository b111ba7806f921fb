// Tests for pcp/nn/rng.hpp and pcp/nn/adam.hpp: seeded streams, normal statistics, Adam against
// a hand-computed step, the learning-rate schedules, and gradient clipping.
#include "pcp/core/error.hpp"
#include "pcp/nn/adam.hpp"
#include "pcp/nn/rng.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp::nn;

TEST_CASE("nn: RNG streams are reproducible and distinct, normals have the right moments", "[nn]") {
    Rng a(42, 0), b(42, 0), c(42, 1), d(43, 0);
    for (int i = 0; i < 10; ++i) {
        const auto x = a.next_u64();
        CHECK(x == b.next_u64());
        CHECK(x != c.next_u64());
        CHECK(x != d.next_u64());
    }
    CHECK(Rng(1, 2).next_u64() != Rng(2, 1).next_u64());
    // State save/restore continues the same sequence.
    Rng e(7, 3);
    e.next_u64();
    const Rng::State s = e.state();
    const auto next = e.next_u64();
    Rng f;
    f.set_state(s);
    CHECK(f.next_u64() == next);
    CHECK_THROWS_AS(f.set_state(Rng::State{{0, 0, 0, 0}}), pcp::Error);
    // Moments of 100k normals, and uniform range.
    Rng g(9, 0);
    double sum = 0, sq = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        const double x = g.normal();
        sum += x;
        sq += x * x;
    }
    CHECK(std::abs(sum / n) < 0.02);
    CHECK(std::abs(sq / n - 1.0) < 0.02);
    for (int i = 0; i < 1000; ++i) {
        const double u = g.uniform();
        CHECK((u >= 0.0 && u < 1.0));
        CHECK(g.below(7) < 7);
    }
}

TEST_CASE("nn: Adam matches a hand-computed step with bias correction", "[nn]") {
    Vec<double> p(2), grad(2);
    p << 1.0, -2.0;
    grad << 0.5, -0.25;
    AdamState<double> st(2);
    const AdamOptions o;
    adam_step<double>(p, grad, st, 0.1, o);
    // Step 1: m_hat = g, v_hat = g^2, update = lr * g / (|g| + eps) = lr * sign(g).
    CHECK(p(0) == Approx(1.0 - 0.1 * 0.5 / (0.5 + 1e-8)).epsilon(1e-12));
    CHECK(p(1) == Approx(-2.0 + 0.1 * 0.25 / (0.25 + 1e-8)).epsilon(1e-12));
    // Step 2 by the textbook formula.
    const Vec<double> p1 = p, m1 = st.m, v1 = st.v;
    Vec<double> g2(2);
    g2 << -1.0, 3.0;
    adam_step<double>(p, g2, st, 0.1, o);
    for (int i = 0; i < 2; ++i) {
        const double m = 0.9 * m1(i) + 0.1 * g2(i);
        const double v = 0.999 * v1(i) + 0.001 * g2(i) * g2(i);
        const double mh = m / (1 - 0.81), vh = v / (1 - 0.999 * 0.999);
        CHECK(p(i) == Approx(p1(i) - 0.1 * mh / (std::sqrt(vh) + 1e-8)).epsilon(1e-12));
    }
    CHECK(st.t == 2);
    Vec<double> wrong(3);
    CHECK_THROWS_AS(adam_step<double>(p, wrong, st, 0.1, o), pcp::Error);
}

TEST_CASE("nn: Adam on a large vector (chunks over the threads) matches the textbook step entry by entry", "[nn]") {
    // More entries than one thread's share and not a multiple of the chunk: every entry, the last
    // chunk's tail included, must get the textbook update, in float with 2 threads as in a run.
    const Eigen::Index n = 100003;
    Rng rng(7, 1);
    Vec<float> p(n), g(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        p(i) = float(rng.normal());
        g(i) = float(rng.normal()) * (i % 5 == 0 ? 1e-3f : 1.0f);
    }
    AdamState<float> st(n);
    const Vec<float> p0 = p;
    const int threads = Eigen::nbThreads();
    Eigen::setNbThreads(2);
    adam_step<float>(p, g, st, 1e-3, AdamOptions{});
    Vec<float> g2 = g.reverse();
    const Vec<float> p1 = p;
    adam_step<float>(p, g2, st, 1e-3, AdamOptions{});
    Eigen::setNbThreads(threads);
    int wrong = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
        const double m1 = 0.1 * g(i), v1 = 0.001 * double(g(i)) * g(i);
        const double e1 = p0(i) - 1e-3 * (m1 / 0.1) / (std::sqrt(v1 / 0.001) + 1e-8);
        const double m = 0.9 * m1 + 0.1 * g2(i), v = 0.999 * v1 + 0.001 * double(g2(i)) * g2(i);
        const double e2 = p1(i) - 1e-3 * (m / (1 - 0.81)) / (std::sqrt(v / (1 - 0.999 * 0.999)) + 1e-8);
        if (std::abs(p1(i) - e1) > 1e-6 + 1e-6 * std::abs(e1) || std::abs(p(i) - e2) > 1e-6 + 1e-6 * std::abs(e2)) ++wrong;
    }
    CHECK(wrong == 0);
    CHECK(st.t == 2);
}

TEST_CASE("nn: learning-rate schedules and gradient clipping", "[nn]") {
    LrSchedule c;
    c.lr = 1e-3;
    CHECK(c.at(0) == 1e-3);
    CHECK(c.at(100000) == 1e-3);
    LrSchedule cos;
    cos.kind = LrSchedule::Kind::Cosine;
    cos.lr = 1e-3;
    cos.warmup_steps = 10;
    cos.total_steps = 110;
    cos.final_lr = 1e-5;
    CHECK(cos.at(0) == Approx(1e-4));
    CHECK(cos.at(9) == Approx(1e-3));
    CHECK(cos.at(10) == Approx(1e-3));
    CHECK(cos.at(60) == Approx(0.5 * (1e-3 + 1e-5)));
    CHECK(cos.at(110) == Approx(1e-5));
    CHECK(cos.at(1000) == Approx(1e-5));

    Vec<float> g1(2), g2(1);
    g1 << 3.0f, 0.0f;
    g2 << 4.0f;
    CHECK(clip_grad_norm<float>({&g1, &g2}, 0.0) == Approx(5.0));  // measure only
    CHECK(g1(0) == 3.0f);
    CHECK(clip_grad_norm<float>({&g1, &g2}, 1.0) == Approx(5.0));
    CHECK(g1(0) == Approx(0.6f));
    CHECK(g2(0) == Approx(0.8f));
    CHECK(clip_grad_norm<float>({&g1, &g2}, 10.0) == Approx(1.0));
    CHECK(g1(0) == Approx(0.6f));
}
