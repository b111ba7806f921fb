// KdTree over nanoflann 1.4 (the only file that includes nanoflann.hpp). Each batched query runs
// an independent nanoflann search per row inside an OpenMP loop; nanoflann's searches are const and
// thread-safe. Distances are returned as Euclidean (nanoflann works in squared distances).
#include "pcp/cloud/kdtree.hpp"

#include "pcp/core/error.hpp"

#include <nanoflann.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

namespace pcp {

namespace {

/// nanoflann's dataset adaptor over a row-major N x 3 float matrix.
struct PointsAdaptor {
    const PointsF* points;
    std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(points->rows()); }
    float kdtree_get_pt(std::uint32_t i, std::size_t dim) const { return (*points)(i, static_cast<Eigen::Index>(dim)); }
    template <class Box>
    bool kdtree_get_bbox(Box&) const { return false; }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, PointsAdaptor, float, std::uint32_t>, PointsAdaptor, 3,
    std::uint32_t>;

constexpr int kLeafSize = 16;

}  // namespace

class KdTree::Impl {
public:
    explicit Impl(const Eigen::Ref<const PointsF>& pts)
        : points(pts), adaptor{&points},
          tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize)) {}
    PointsF points;
    PointsAdaptor adaptor;
    Tree tree;
    // sampling_scale(tree), measured once: every mesh stage asks for it, and at a million points
    // it is a second of 11-nearest-neighbour queries.
    std::once_flag scale_once;
    double scale = 0;
};

KdTree::KdTree(const Eigen::Ref<const PointsF>& points) {
    PCP_CHECK(points.rows() > 0, "KdTree: no points");
    PCP_CHECK(points.rows() < std::numeric_limits<std::int32_t>::max(), "KdTree: too many points");
    impl_ = std::make_unique<Impl>(points);
}

KdTree::~KdTree() = default;
KdTree::KdTree(KdTree&&) noexcept = default;
KdTree& KdTree::operator=(KdTree&&) noexcept = default;

Eigen::Index KdTree::size() const { return impl_->points.rows(); }
const PointsF& KdTree::points() const { return impl_->points; }

std::int32_t KdTree::nearest_point(const Eigen::Vector3f& q, float* distance) const {
    std::uint32_t index = 0;
    float dist_sq = 0.0f;
    impl_->tree.knnSearch(q.data(), 1, &index, &dist_sq);
    if (distance) *distance = std::sqrt(dist_sq);
    return static_cast<std::int32_t>(index);
}

IndexVector KdTree::nearest(const Eigen::Ref<const PointsF>& queries, Eigen::VectorXf* distances) const {
    const Eigen::Index m = queries.rows();
    IndexVector indices(m);
    if (distances) distances->resize(m);
    const Tree& tree = impl_->tree;
#pragma omp parallel for schedule(static, 1024)
    for (Eigen::Index i = 0; i < m; ++i) {
        const float q[3] = {queries(i, 0), queries(i, 1), queries(i, 2)};
        std::uint32_t index = 0;
        float dist_sq = 0.0f;
        tree.knnSearch(q, 1, &index, &dist_sq);
        indices(i) = static_cast<std::int32_t>(index);
        if (distances) (*distances)(i) = std::sqrt(dist_sq);
    }
    return indices;
}

void KdTree::knn(const Eigen::Ref<const PointsF>& queries, int k, NeighborIndices& indices,
                 NeighborDistances& distances) const {
    PCP_CHECK(k >= 1 && k <= size(), "KdTree::knn: k = " << k << " must be in [1, " << size() << "]");
    const Eigen::Index m = queries.rows();
    indices.resize(m, k);
    distances.resize(m, k);
    const Tree& tree = impl_->tree;
#pragma omp parallel
    {
        std::vector<std::uint32_t> idx(static_cast<std::size_t>(k));
        std::vector<float> dist_sq(static_cast<std::size_t>(k));
#pragma omp for schedule(static, 256)
        for (Eigen::Index i = 0; i < m; ++i) {
            const float q[3] = {queries(i, 0), queries(i, 1), queries(i, 2)};
            tree.knnSearch(q, static_cast<std::size_t>(k), idx.data(), dist_sq.data());
            for (int j = 0; j < k; ++j) {
                indices(i, j) = static_cast<std::int32_t>(idx[static_cast<std::size_t>(j)]);
                distances(i, j) = std::sqrt(dist_sq[static_cast<std::size_t>(j)]);
            }
        }
    }
}

Eigen::VectorXf KdTree::kth_distance(const Eigen::Ref<const PointsF>& queries, int k) const {
    PCP_CHECK(k >= 1 && k <= size(),
              "KdTree::kth_distance: k = " << k << " must be in [1, " << size() << "]");
    const Eigen::Index m = queries.rows();
    Eigen::VectorXf result(m);
    const Tree& tree = impl_->tree;
#pragma omp parallel
    {
        std::vector<std::uint32_t> idx(static_cast<std::size_t>(k));
        std::vector<float> dist_sq(static_cast<std::size_t>(k));
#pragma omp for schedule(static, 256)
        for (Eigen::Index i = 0; i < m; ++i) {
            const float q[3] = {queries(i, 0), queries(i, 1), queries(i, 2)};
            tree.knnSearch(q, static_cast<std::size_t>(k), idx.data(), dist_sq.data());
            result(i) = std::sqrt(dist_sq[static_cast<std::size_t>(k - 1)]);
        }
    }
    return result;
}

double KdTree::sampling_scale() const {
    std::call_once(impl_->scale_once, [this] {
        if (size() < 2) return;
        Eigen::VectorXf d = kth_distance(points(), static_cast<int>(std::min<Eigen::Index>(11, size())));
        float* mid = d.data() + d.size() / 2;
        std::nth_element(d.data(), mid, d.data() + d.size());
        impl_->scale = static_cast<double>(*mid);
    });
    return impl_->scale;
}

double sampling_scale(const KdTree& tree) { return tree.sampling_scale(); }

}  // namespace pcp
