// The comparison's plan (airmass/compare_plan.hpp over compare/plan.json): the table as built
// into the library, what a plan renders for its paths, and the refusal of bad inputs with the
// option named. tests/python/test_compare_plan.py checks the same table through the CLI and
// against the file itself; here the library is asked directly.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

#include "airmass/compare_plan.hpp"

namespace {

using namespace airmass::compare;

TEST(ComparePlan, TableIsTheFilesPaths) {
    const auto& table = path_table();
    ASSERT_EQ(table.size(), 7u);  // compare/plan.json: four Blender paths, three POV-Ray paths
    std::set<std::string> names;
    int blender = 0;
    for (const PathInfo& p : table) {
        EXPECT_TRUE(names.insert(p.name).second) << p.name;
        EXPECT_FALSE(p.label.empty() || p.description.empty() || p.title.empty() || p.renders.empty()) << p.name;
        EXPECT_GT(p.step_cost, 0.0) << p.name;
        EXPECT_FALSE(p.volume_modes && p.ms_modes) << p.name;
        blender += p.renderer == Renderer::blender;
    }
    EXPECT_EQ(blender, 4);
    EXPECT_EQ(path_names(true), "sky_texture,analytic_volume,vdb_volume");
    EXPECT_EQ(path_info("vdb_volume").reference, "native_matched_box");
    EXPECT_TRUE(path_info("vdb_volume").volume_modes);
    EXPECT_TRUE(path_info("analytic_volume_ms").ms_modes);
    EXPECT_EQ(path_info("pov_df3").renderer, Renderer::povray);
    EXPECT_THROW(path_info("sky"), std::logic_error);
    EXPECT_EQ(job_format(), "airmass-compare-job");
    EXPECT_EQ(job_schema_version(), 2);
}

TEST(ComparePlan, PlanRendersWhatItsPathsNeed) {
    PlanInputs in;
    in.paths = "vdb_volume,pov_sky";
    const Plan plan = make_plan(in);
    // The natives every run makes, then the paths' own, in the one order.
    EXPECT_EQ(plan.natives, (std::vector<std::string>{"native_physical", "native_physical_box", "native_hg_spectral",
                                                      "native_matched", "native_matched_box"}));
    EXPECT_TRUE(plan.needs_view_box());
    EXPECT_TRUE(plan.needs_constituents());
    EXPECT_TRUE(std::find(plan.steps.begin(), plan.steps.end(), "vdb_export") != plan.steps.end());
    EXPECT_TRUE(std::find(plan.steps.begin(), plan.steps.end(), "pov_scene pov_sky") != plan.steps.end());
    EXPECT_EQ(plan.steps.back(), "report");
    EXPECT_EQ(plan.seeds["pov_sky"], 1);
    EXPECT_EQ(plan.seeds["vdb_volume"], in.seeds);
    const auto header = job_header(plan);
    EXPECT_EQ(header["format"], job_format());
    EXPECT_EQ(header["schema_version"], job_schema_version());

    in.paths = "sky_texture";
    in.renderers = false;
    const Plan natives_only = make_plan(in);
    EXPECT_FALSE(natives_only.needs_view_box());
    EXPECT_FALSE(natives_only.needs_constituents());
    EXPECT_EQ(natives_only.steps.back(), "sky_texture_input");  // no renderer step, no report
}

// A bad input names the option and its range or its allowed values.
void expect_refused(const PlanInputs& in, const std::string& named) {
    try {
        (void)make_plan(in);
        ADD_FAILURE() << "accepted; expected a refusal naming " << named;
    } catch (const PlanError& e) {
        EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
    }
}

TEST(ComparePlan, BadInputsAreRefusedByName) {
    PlanInputs in;
    in.seeds = 1;
    expect_refused(in, "--seeds");
    in = {};
    in.paths = "sky_texture,sky";
    expect_refused(in, "'sky' is not one of sky_texture, analytic_volume");
    in = {};
    in.volume_modes = "";
    expect_refused(in, "--volume-modes: empty");
    in = {};
    in.step_km = 0.0;
    expect_refused(in, "--step");
    in = {};
    in.sky_oversample = 17.0;
    expect_refused(in, "--sky-oversample 17");
}

}  // namespace
