// Real-data checks for pcp/io.hpp on ../shared/data (PCP_DATA_DIR): the benchmark inputs and
// ground-truth files read with the counts, properties and first values their headers promise,
// and every case listed in MANIFEST.tsv reads with its stated point count.
#include "pcp/io/io.hpp"

#include <catch2/catch.hpp>

#include <fstream>
#include <sstream>

namespace {
std::string data_path(const std::string& rel) { return std::string(PCP_DATA_DIR) + "/" + rel; }
}  // namespace

TEST_CASE("io realdata: ABC input, sdf samples and ground-truth mesh", "[io][realdata]") {
    const pcp::PointCloud input = pcp::read_point_cloud(data_path("abc/abc_00010039/input.ply"));
    REQUIRE(input.points.rows() == 6936);
    CHECK(input.properties.empty());
    // First vertex, as float32 in the file (checked with Python's struct module).
    CHECK(input.points(0, 0) == static_cast<double>(0.34077516198158264f));
    CHECK(input.points(0, 2) == static_cast<double>(0.33974388241767883f));

    const pcp::PointCloud sdf = pcp::read_point_cloud(data_path("abc/abc_00010039/sdf_samples.ply"));
    REQUIRE(sdf.points.rows() == 2000);
    REQUIRE(sdf.properties.count("sdf") == 1);
    CHECK(sdf.properties.at("sdf").size() == 2000);
    CHECK(sdf.properties.at("sdf")(0) == static_cast<double>(-0.44694992899894714f));
    CHECK(sdf.properties.at("sdf").minCoeff() < 0.0);
    CHECK(sdf.properties.at("sdf").maxCoeff() > 0.0);

    const pcp::Mesh gt = pcp::read_mesh(data_path("abc/abc_00010039/gt.ply"));
    CHECK(gt.vertices.rows() == 3803);
    CHECK(gt.faces.rows() == 7638);
    CHECK(gt.faces.minCoeff() >= 0);
    CHECK(gt.faces.maxCoeff() < 3803);
}

TEST_CASE("io realdata: kitten.xyz with normals", "[io][realdata]") {
    const pcp::PointCloud kitten = pcp::read_point_cloud(data_path("scans/kitten.xyz"));
    REQUIRE(kitten.points.rows() == 5210);
    REQUIRE(kitten.properties.size() == 3);
    CHECK(kitten.points.row(0) == Eigen::RowVector3d(-0.0721898, -0.159749, -0.108444));
    CHECK(kitten.properties.at("nz")(0) == -0.0690972);
    Eigen::VectorXd norms(5210);
    for (Eigen::Index i = 0; i < 5210; ++i)
        norms(i) = Eigen::Vector3d(kitten.properties.at("nx")(i), kitten.properties.at("ny")(i),
                                   kitten.properties.at("nz")(i)).norm();
    CHECK(norms.minCoeff() > 0.99);
    CHECK(norms.maxCoeff() < 1.01);
}

TEST_CASE("io realdata: living-room fragment with double coordinates and colours", "[io][realdata]") {
    const pcp::PointCloud room = pcp::read_point_cloud(data_path("scenes/livingroom_fragment.ply"));
    REQUIRE(room.points.rows() == 112698);
    CHECK(room.points(0, 0) == 0.7579967345321682);
    for (const char* c : {"red", "green", "blue"}) {
        REQUIRE(room.properties.count(c) == 1);
        CHECK(room.properties.at(c).minCoeff() >= 0);
        CHECK(room.properties.at(c).maxCoeff() <= 255);
    }
    CHECK(room.properties.at("red")(0) == 165);
    CHECK(room.properties.at("blue")(0) == 191);
}

TEST_CASE("io realdata: every MANIFEST case reads with its stated point count", "[io][realdata]") {
    std::ifstream manifest(data_path("MANIFEST.tsv"));
    REQUIRE(manifest);
    std::string line;
    std::getline(manifest, line);  // column names
    int cases = 0;
    while (std::getline(manifest, line)) {
        std::istringstream row(line);
        std::string name, category, input, gt_mesh, gt_sdf, points;
        std::getline(row, name, '\t');
        std::getline(row, category, '\t');
        std::getline(row, input, '\t');
        std::getline(row, gt_mesh, '\t');
        std::getline(row, gt_sdf, '\t');
        std::getline(row, points, '\t');
        INFO(name);
        CHECK(pcp::read_point_cloud(data_path(input)).points.rows() == std::stoll(points));
        if (gt_mesh != "-") {
            const pcp::Mesh mesh = pcp::read_mesh(data_path(gt_mesh));
            CHECK(mesh.faces.rows() > 0);
            CHECK(mesh.faces.maxCoeff() < mesh.vertices.rows());
        }
        if (gt_sdf != "-") CHECK(pcp::read_point_cloud(data_path(gt_sdf)).properties.count("sdf") == 1);
        ++cases;
    }
    CHECK(cases >= 17);
}
