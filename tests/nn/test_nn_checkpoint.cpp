// Tests for pcp/nn/checkpoint.hpp: network files round-trip (including float -> double), and
// truncated, corrupt, foreign and other-version files are rejected with errors naming the file
// and the problem.
#include "pcp/core/error.hpp"
#include "pcp/nn/checkpoint.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

using namespace pcp::nn;
namespace fs = std::filesystem;

namespace {

std::string tmp_file(const std::string& name) {
    const fs::path dir = fs::path(PCP_TEST_TMP_DIR) / "nn_checkpoint";
    fs::create_directories(dir);
    return (dir / name).string();
}

std::string slurp(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void spit(const std::string& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}

NetFile<float> sample_file() {
    Rng rng(11, 0);
    BranchMlp<float> F(decoder_shape(8, 16, 3));
    init_decoder_geometric(F, rng);
    PointNet<float> E(pointnet_shape(8, 32, 16));
    init_pointnet(E, rng);
    AdamState<float> adam(F.layout.size());
    adam.m.setRandom();
    adam.v = adam.m.cwiseAbs();
    adam.t = 42;
    NetFile<float> f;
    f.step = 1234;
    f.nets.push_back(make_record("decoder", F, &adam));
    f.nets.push_back(make_record("encoder", E));
    return f;
}

}  // namespace

TEST_CASE("nn: network files round-trip networks, Adam state, step and RNG", "[nn]") {
    const std::string path = tmp_file("roundtrip.pcpn");
    const NetFile<float> f = sample_file();
    save_net_file(path, f);
    const NetFile<float> g = load_net_file<float>(path);
    CHECK(g.step == 1234);
    REQUIRE(g.nets.size() == 2);
    const BranchMlp<float> F = to_branch_mlp(g.get("decoder"));
    CHECK(F.shape == decoder_shape(8, 16, 3));
    CHECK(F.params == f.nets[0].params);
    CHECK(g.get("decoder").has_adam);
    CHECK(g.get("decoder").adam.t == 42);
    CHECK(g.get("decoder").adam.m == f.nets[0].adam.m);
    CHECK(g.get("decoder").adam.v == f.nets[0].adam.v);
    const PointNet<float> E = to_pointnet(g.get("encoder"));
    CHECK(E.shape == pointnet_shape(8, 32, 16));
    CHECK(E.params == f.nets[1].params);
    CHECK_FALSE(g.get("encoder").has_adam);
    CHECK_THROWS_WITH(g.get("query"), Catch::Contains("no network called 'query'"));
    CHECK_THROWS_WITH(to_pointnet(g.get("decoder")), Catch::Contains("is not a PointNet"));
    // Stored as float, loaded as double: same values.
    const NetFile<double> d = load_net_file<double>(path);
    CHECK(d.get("decoder").params == f.nets[0].params.cast<double>());
    // Stored as double.
    const std::string path_d = tmp_file("roundtrip_d.pcpn");
    save_net_file(path_d, d);
    CHECK(load_net_file<double>(path_d).get("encoder").params == d.get("encoder").params);
}

TEST_CASE("nn: a record whose shape disagrees with its parameters is refused before any allocation", "[nn][fuzz]") {
    // Found by tests/fuzz/fuzz_netfile.cpp: a damaged shape (checksum intact) asked for a network
    // of 2^60 parameters before the parameter count was compared.
    NetRecord<float> branch;
    branch.name = "query_net";
    branch.kind = NetKind::BranchMlp;
    branch.shape = {3, 0, 1 << 30, 8, 1};
    branch.params = Vec<float>::Zero(10);
    CHECK_THROWS_WITH(to_branch_mlp(branch), Catch::Contains("query_net") && Catch::Contains("10 parameters stored"));
    branch.shape = {3, 0, -4, 8, 1};
    CHECK_THROWS_WITH(to_branch_mlp(branch), Catch::Contains("invalid shape"));
    NetRecord<float> pointnet;
    pointnet.name = "encoder";
    pointnet.kind = NetKind::PointNet;
    pointnet.shape = {2, 3, 1 << 30, 2, 1 << 30, 8};
    pointnet.params = Vec<float>::Zero(10);
    CHECK_THROWS_WITH(to_pointnet(pointnet), Catch::Contains("encoder") && Catch::Contains("10 parameters stored"));
}

TEST_CASE("nn: damaged network files are rejected with a clear error", "[nn]") {
    const std::string good = tmp_file("good.pcpn");
    save_net_file(good, sample_file());
    const std::string bytes = slurp(good);
    const std::string bad = tmp_file("bad.pcpn");

    SECTION("truncated") {
        for (std::size_t keep : {std::size_t(3), std::size_t(20), bytes.size() / 2, bytes.size() - 1}) {
            spit(bad, bytes.substr(0, keep));
            CHECK_THROWS_WITH(load_net_file<float>(bad),
                              Catch::Contains(bad) && Catch::Contains("truncated"));
        }
    }
    SECTION("corrupt payload (checksum)") {
        std::string b = bytes;
        b[bytes.size() / 2] ^= 0x10;
        spit(bad, b);
        CHECK_THROWS_WITH(load_net_file<float>(bad),
                          Catch::Contains(bad) && Catch::Contains("checksum mismatch"));
    }
    SECTION("trailing bytes") {
        spit(bad, bytes + "xx");
        CHECK_THROWS_WITH(load_net_file<float>(bad), Catch::Contains("trailing bytes"));
    }
    SECTION("wrong magic") {
        std::string b = bytes;
        b[0] = 'X';
        spit(bad, b);
        CHECK_THROWS_WITH(load_net_file<float>(bad),
                          Catch::Contains(bad) && Catch::Contains("bad magic"));
        spit(bad, "ply\nformat ascii 1.0\n");
        CHECK_THROWS_WITH(load_net_file<float>(bad), Catch::Contains("bad magic"));
    }
    SECTION("wrong version") {
        std::string b = bytes;
        const std::uint32_t v = kNetFileVersion + 1;
        std::memcpy(&b[8], &v, 4);
        spit(bad, b);
        CHECK_THROWS_WITH(load_net_file<float>(bad),
                          Catch::Contains(bad) && Catch::Contains("format version 2") &&
                              Catch::Contains("reads version 1"));
    }
    SECTION("missing file") {
        CHECK_THROWS_WITH(load_net_file<float>(tmp_file("nope.pcpn")),
                          Catch::Contains("cannot open"));
    }
}
