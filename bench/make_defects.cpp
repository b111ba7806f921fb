// pcp_make_defects (MESH | --builtin) -o DIR [--name NAME] [--points N] [--seed S] [--classes a,b,...]:
// clouds with the defects of real scans made from a ground-truth mesh (pcp/eval/defects.hpp), one
// case per class: DIR/NAME_CLASS/input.ply and gt.ply, and a row each in DIR/MANIFEST.tsv (written
// with its header when new; the columns of ../shared/data/MANIFEST.tsv), so that
// bench/run_benchmarks.sh --manifest DIR/MANIFEST.tsv measures PCP and the Poisson baselines on them.
// --builtin: the library's built-in shape (block, through-hole, fin), meshed by marching cubes at 256
// cells. A tool, not part of the library; the clouds of a shared mesh stay outside the repository.
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/eval/defects.hpp"
#include "pcp/io/io.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace {

pcp::Mesh builtin_mesh() {
    pcp::Aabb box;
    box.min = Eigen::Vector3d::Constant(-0.7);
    box.max = Eigen::Vector3d::Constant(0.7);
    pcp::SdfGridOptions o;
    o.band = pcp::NarrowBand::Dense;
    const pcp::SdfBatchFn sdf = [](const Eigen::Ref<const pcp::PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) {
        for (Eigen::Index i = 0; i < q.rows(); ++i) v(i) = static_cast<float>(pcp::default_shape_sdf(q.row(i).transpose().cast<double>()));
    };
    return pcp::marching_cubes(pcp::evaluate_sdf_grid(sdf, pcp::make_grid_spec(box, 256, 0.0), o));
}

}  // namespace

int main(int argc, char** argv) {
    const char* usage = "usage: pcp_make_defects (MESH | --builtin) -o DIR [--name NAME] [--points N] [--seed S] [--classes a,b,...]\n";
    try {
        std::string mesh_path, dir, name, classes;
        bool builtin = false;
        pcp::DefectOptions o;
        for (int i = 1; i < argc; ++i) {
            const std::string a = argv[i];
            const auto value = [&]() -> std::string {
                if (i + 1 >= argc) throw pcp::Error(a + " needs a value");
                return argv[++i];
            };
            if (a == "-o") dir = value();
            else if (a == "--name") name = value();
            else if (a == "--points") o.points = std::stol(value());
            else if (a == "--seed") o.seed = std::stoull(value());
            else if (a == "--classes") classes = value();
            else if (a == "--builtin") builtin = true;
            else if (!a.empty() && a[0] != '-' && mesh_path.empty()) mesh_path = a;
            else {
                std::cerr << usage;
                return 2;
            }
        }
        if (dir.empty() || builtin == !mesh_path.empty()) {
            std::cerr << usage;
            return 2;
        }
        if (name.empty()) name = builtin ? "builtin" : std::filesystem::path(mesh_path).parent_path().filename().string();
        std::vector<pcp::Defect> selected;
        if (classes.empty()) selected = pcp::all_defects();
        std::stringstream list(classes);
        for (std::string c; std::getline(list, c, ',');) selected.push_back(pcp::parse_defect(c));
        if (o.points < 100) throw pcp::Error("--points must be at least 100, got " + std::to_string(o.points));
        const pcp::Mesh mesh = builtin ? builtin_mesh() : pcp::read_mesh(mesh_path);
        (void)pcp::make_defect_cloud(mesh, pcp::Defect::Sparse, o);  // a mesh it cannot sample is refused before any output
        std::error_code ec;
        std::filesystem::create_directories(dir, ec);
        if (ec || !std::filesystem::is_directory(dir)) throw pcp::Error(dir + ": cannot create the output directory");
        const std::string manifest = dir + "/MANIFEST.tsv";
        const bool fresh = !std::filesystem::exists(manifest);
        std::ofstream rows(manifest, std::ios::app);
        if (fresh) rows << "name\tcategory\tinput\tgt_mesh\tgt_sdf\tpoints\tnote\tsource\tlicense\n";
        for (pcp::Defect d : selected) {
            const std::string c = pcp::to_string(d), case_name = name + "_" + c, case_dir = dir + "/" + case_name;
            std::filesystem::create_directories(case_dir);
            pcp::PointCloud cloud;
            cloud.points = pcp::make_defect_cloud(mesh, d, o);
            pcp::write_point_cloud(case_dir + "/input.ply", cloud);
            pcp::write_mesh(case_dir + "/gt.ply", mesh);
            rows << case_name << "\t" << c << "\t" << case_name << "/input.ply\t" << case_name << "/gt.ply\t-\t" << cloud.points.rows()
                 << "\tpcp_make_defects " << c << " seed " << o.seed << "\t" << (builtin ? "built-in shape" : mesh_path)
                 << "\tas its mesh\n";
            std::cout << "pcp_make_defects: " << case_dir << "/input.ply (" << cloud.points.rows() << " points, " << c << ")\n";
        }
        return rows ? 0 : 1;
    } catch (const std::exception& e) {
        std::cerr << "pcp_make_defects: error: " << e.what() << "\n";
        return 1;
    }
}
