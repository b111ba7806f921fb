// Probe for issue 7's optional oneDNN back end: the rate of oneDNN's matmul (bf16 inputs with
// fp32 output and accumulation, and fp32) against nn::gemm's back ends on the shapes of the
// method's layers (H x H times H x N). Built only where CMake finds oneDNN (Debian libdnnl-dev).
// "bf16 + convert" also times the conversion of both fp32 operands to bf16 (oneDNN reorders),
// which a back end with fp32 master weights pays on every call. Threads: OMP_NUM_THREADS / all
// cores for both libraries. Prints a Markdown table. Usage: bench_gemm_dnnl
#include "pcp/nn/gemm.hpp"

#include <oneapi/dnnl/dnnl.hpp>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <vector>

namespace {

/// Median wall time of `runs` calls of `f` after one warm-up call.
double median_seconds(const std::function<void()>& f, int runs = 11) {
    f();
    std::vector<double> t;
    for (int r = 0; r < runs; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::nth_element(t.begin(), t.begin() + runs / 2, t.end());
    return t[runs / 2];
}

}  // namespace

int main() {
    using dnnl::memory;
    const dnnl::engine engine(dnnl::engine::kind::cpu, 0);
    dnnl::stream stream(engine);
    std::printf("threads %d; GFLOP/s of C (H x N) = A (H x H) * B (H x N), median of 11 calls\n\n", omp_get_max_threads());
    std::printf("| H | N | nn::gemm eigen | nn::gemm blas | oneDNN f32 | oneDNN bf16 | oneDNN bf16 + convert | bf16 kernel |\n");
    std::printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (const int H : {256, 512}) {
        for (const int N : {400, 2000, 5000}) {
            const double flops = pcp::nn::gemm_flops(H, N, H);
            Eigen::MatrixXf A = Eigen::MatrixXf::Random(H, H), B = Eigen::MatrixXf::Random(H, N), C(H, N);
            double rate[2] = {0, 0};
            for (const auto backend : {pcp::nn::GemmBackend::Eigen, pcp::nn::GemmBackend::Blas}) {
                if (!pcp::nn::gemm_backend_available(backend)) continue;
                pcp::nn::set_gemm_backend(backend);
                rate[backend == pcp::nn::GemmBackend::Blas] =
                    flops / median_seconds([&] { pcp::nn::gemm<float>(C, A, B, 1.0f, 0.0f); }) / 1e9;
            }
            // oneDNN row-major: C^T (N x H) = B^T (N x H) * A^T (H x H); column-major Eigen data
            // are exactly these row-major transposes, so no copies are needed.
            const memory::desc a32({N, H}, memory::data_type::f32, memory::format_tag::ab);
            const memory::desc w32({H, H}, memory::data_type::f32, memory::format_tag::ab);
            const memory::desc a16({N, H}, memory::data_type::bf16, memory::format_tag::ab);
            const memory::desc w16({H, H}, memory::data_type::bf16, memory::format_tag::ab);
            const memory::desc dst({N, H}, memory::data_type::f32, memory::format_tag::ab);
            memory src32(a32, engine, B.data()), wei32(w32, engine, A.data()), out(dst, engine, C.data());
            memory src16(a16, engine), wei16(w16, engine);
            const dnnl::matmul mm32(dnnl::matmul::primitive_desc(dnnl::matmul::desc(a32, w32, dst), engine));
            const dnnl::matmul::primitive_desc pd16(dnnl::matmul::desc(a16, w16, dst), engine);
            const dnnl::matmul mm16(pd16);
            const dnnl::reorder to16a(src32, src16), to16w(wei32, wei16);
            const double f32 = flops / median_seconds([&] {
                mm32.execute(stream, {{DNNL_ARG_SRC, src32}, {DNNL_ARG_WEIGHTS, wei32}, {DNNL_ARG_DST, out}});
                stream.wait();
            }) / 1e9;
            to16a.execute(stream, src32, src16);
            to16w.execute(stream, wei32, wei16);
            const double bf16 = flops / median_seconds([&] {
                mm16.execute(stream, {{DNNL_ARG_SRC, src16}, {DNNL_ARG_WEIGHTS, wei16}, {DNNL_ARG_DST, out}});
                stream.wait();
            }) / 1e9;
            const double bf16_convert = flops / median_seconds([&] {
                to16a.execute(stream, src32, src16);
                to16w.execute(stream, wei32, wei16);
                mm16.execute(stream, {{DNNL_ARG_SRC, src16}, {DNNL_ARG_WEIGHTS, wei16}, {DNNL_ARG_DST, out}});
                stream.wait();
            }) / 1e9;
            std::printf("| %d | %d | %.1f | %.1f | %.1f | %.1f | %.1f | %s |\n", H, N, rate[0], rate[1], f32, bf16, bf16_convert,
                        pd16.impl_info_str());
        }
    }
    return 0;
}
