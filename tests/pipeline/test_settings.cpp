// Tests for pcp/settings.hpp: every setting reads back what it is set to, every preset passes the
// validator, ReconstructOptions{} is the default preset, the paper preset has the paper's sizes,
// and out-of-range values are refused with one line naming the setting and the value.
#include "pcp/core/error.hpp"
#include "pcp/settings.hpp"

#include <catch2/catch.hpp>

#include <set>
#include <string>

namespace {

/// Every setting's value as text.
std::vector<std::string> values(const pcp::ReconstructOptions& o) {
    std::vector<std::string> out;
    for (const pcp::Setting& s : pcp::reconstruct_settings()) out.push_back(s.name + "=" + s.get(o));
    return out;
}

}  // namespace

TEST_CASE("settings: names are unique, every preset passes the validator and reads back through the table", "[settings]") {
    std::set<std::string> names;
    for (const pcp::Setting& s : pcp::reconstruct_settings()) {
        INFO(s.name);
        CHECK(names.insert(s.name).second);
        CHECK(pcp::find_setting(s.name) == &s);
        CHECK_FALSE(s.help.empty());
        CHECK_FALSE(s.range.empty());
    }
    for (const char* preset : {"default", "fast", "paper", "scene"}) {
        INFO(preset);
        const pcp::ReconstructOptions o = pcp::ReconstructOptions::preset(preset);
        CHECK_NOTHROW(pcp::check_options(o));
        // Setting every value to what it reads changes nothing but the prior source, which the
        // self-prior's own settings imply.
        pcp::ReconstructOptions again = o;
        for (const pcp::Setting& s : pcp::reconstruct_settings())
            if (s.group != "Prior (stage 1)" || s.name == "prior-source" || s.name == "prior-tune-steps") pcp::set_option(again, s.name, s.get(o));
        CHECK(values(again) == values(o));
    }
}

TEST_CASE("settings: ReconstructOptions{} is the default preset, the paper preset has the paper's sizes", "[settings]") {
    CHECK(values(pcp::ReconstructOptions{}) == values(pcp::ReconstructOptions::preset("default")));
    const pcp::ReconstructOptions paper = pcp::ReconstructOptions::preset("paper");
    CHECK(paper.prior_source == pcp::PriorSource::SelfPrior);
    CHECK(paper.fit.width == 512);
    CHECK(paper.fit.depth == 8);
    CHECK(paper.fit.queries_per_step == 400);
    CHECK(paper.fit.schedule.learning_rate == 1e-4);
    CHECK(paper.fit.sampling.uniform_fraction == 0.0f);
    CHECK_FALSE(paper.denoise.automatic);
    CHECK_FALSE(paper.winding_sign.enabled);
    CHECK(paper.resolution == 128);
    const pcp::ReconstructOptions d;
    CHECK(d.prior_source == pcp::PriorSource::Builtin);
    CHECK(d.fit.steps == 2400);
    CHECK(pcp::ReconstructOptions::preset("fast").fit.steps == 2000);
    CHECK(pcp::ReconstructOptions::preset("scene").scene.enabled);
}

TEST_CASE("settings: bad values are refused naming the setting and the value, the self-prior's settings imply it", "[settings]") {
    pcp::ReconstructOptions o;
    CHECK_THROWS_WITH(pcp::set_option(o, "resolution", "4"), "resolution must be in [8, 2048] (got '4')");
    CHECK_THROWS_WITH(pcp::set_option(o, "resolution", "12x"), "resolution must be in [8, 2048] (got '12x')");
    CHECK_THROWS_WITH(pcp::set_option(o, "winding-near", "-3"), "winding-near must be in [0, 100] (got '-3')");
    CHECK_THROWS_WITH(pcp::set_option(o, "sign-repair", "yes"), "sign-repair must be on or off (got 'yes')");
    CHECK_THROWS_WITH(pcp::set_option(o, "thin-offset", "0.1"), "thin-offset must be in [0, 0.1) (got '0.1')");
    CHECK_THROWS_WITH(pcp::set_option(o, "lr", "nan"), "lr must be > 0 (got 'nan')");
    CHECK_THROWS_WITH(pcp::set_option(o, "no-such-thing", "1"), Catch::Contains("unknown setting 'no-such-thing'"));
    CHECK_THROWS_WITH(pcp::set_option(o, "sheet-gap", "-1"), "sheet-gap must be in [0, 0.1) (got '-1')");
    pcp::set_option(o, "sheet-gap", "0");
    CHECK_FALSE(o.sheet_gap.enabled);
    pcp::set_option(o, "sheet-gap", "0.003");
    CHECK(o.sheet_gap.enabled);
    CHECK(o.sheet_gap.min_gap == 0.003);
    pcp::set_option(o, "grid-far-levels", "2");
    CHECK(o.sign_repair.far_levels == 2);  // both grids
    pcp::set_option(o, "spreads", "0.25,1");
    CHECK(o.self_prior.sampling.spreads == std::vector<float>{0.25f, 1.0f});  // both stages
    pcp::set_option(o, "smooth", "on");
    CHECK((o.smoothing.enabled && o.noisy.smooth));
    CHECK(pcp::find_setting("smooth")->get(o) == "on");
    CHECK(pcp::find_setting("smooth")->get(pcp::ReconstructOptions{}) == "auto");
    CHECK(o.prior_source == pcp::PriorSource::Builtin);
    pcp::set_option(o, "prior-steps", "50");
    CHECK(o.prior_source == pcp::PriorSource::SelfPrior);
    // The validator sees what the table cannot: max-points against the spread's neighbours.
    o = {};
    o.max_fit_points = 10;
    CHECK_THROWS_WITH(pcp::check_options(o), Catch::Contains("max-points must be 0 or >="));
    o = {};
    o.resolution = 4;  // set in code, not through the table: the validator still refuses it
    CHECK_THROWS_WITH(pcp::check_options(o), "resolution must be in [8, 2048] (got '4')");
}
