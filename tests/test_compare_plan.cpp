// The comparison's plan (airmass/compare_plan.hpp over compare/plan.json): the table as built
// into the library, what a plan renders for its paths, and the refusal of bad inputs with the
// option named. tests/python/test_compare_plan.py checks the same table through the CLI and
// against the file itself; here the library is asked directly.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <tuple>
#include <vector>

#include "airmass/compare_plan.hpp"

namespace {

using namespace airmass::compare;

TEST(ComparePlan, TableIsTheFilesPaths) {
    // The paths the CLI, blender_render.py and report.py run by name (a rename or an addition in
    // compare/plan.json needs code there too: this fails first), their renderers and the add-on's
    // checkbox bits, which saved .blend files hold (they must never move).
    const std::vector<std::tuple<std::string, Renderer, int>> expected = {
        {"sky_texture", Renderer::blender, 1},   {"analytic_volume", Renderer::blender, 2},
        {"analytic_volume_ms", Renderer::blender, 8}, {"vdb_volume", Renderer::blender, 4},
        {"pov_sky", Renderer::povray, 0},         {"pov_analytic", Renderer::povray, 0},
        {"pov_df3", Renderer::povray, 0}};
    const auto& table = path_table();
    ASSERT_EQ(table.size(), expected.size());
    for (std::size_t i = 0; i < table.size(); ++i) {
        const PathInfo& p = table[i];
        EXPECT_EQ(p.name, std::get<0>(expected[i]));
        EXPECT_EQ(p.renderer, std::get<1>(expected[i])) << p.name;
        EXPECT_EQ(p.addon_flag, std::get<2>(expected[i])) << p.name;
        EXPECT_FALSE(p.label.empty() || p.description.empty() || p.title.empty() || p.renders.empty()) << p.name;
        EXPECT_GT(p.step_cost, 0.0) << p.name;
        EXPECT_FALSE(p.volume_modes && p.ms_modes) << p.name;
    }
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

// A malformed plan document is refused naming the path and the field.
void expect_malformed(const std::string& doc, const std::string& named) {
    try {
        (void)detail::parse_plan(doc);
        ADD_FAILURE() << "accepted; expected a refusal naming " << named;
    } catch (const std::logic_error& e) {
        EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
    }
}

std::string path_doc(const std::string& name, const std::string& renderer, const std::string& flag,
                     const std::string& extra = "") {
    return R"({"name": ")" + name + R"(", "addon_flag": )" + flag +
           R"(, "label": "L", "description": "D", "title": "T", "reference": "native_matched", "renderer": ")" +
           renderer + R"(", "renders": "R", "natives": [], "modes": null, "default": true, "step_cost": 1.0,
           "render_count": "1")" + extra + "}";
}

std::string plan_doc(const std::string& paths) {
    return R"({"format": "airmass-compare-plan", "job_format": "airmass-compare-job", "job_schema_version": 2,
              "paths": [)" + paths + "]}";
}

TEST(ComparePlan, MalformedDocumentsAreRefusedByField) {
    // A well-formed document parses (the helpers below are right).
    const auto ok = detail::parse_plan(plan_doc(path_doc("a", "blender", "1") + "," + path_doc("b", "povray", "null")));
    ASSERT_EQ(ok.paths.size(), 2u);
    EXPECT_EQ(ok.paths[0].addon_flag, 1);
    EXPECT_EQ(ok.paths[1].renderer, Renderer::povray);

    expect_malformed("{", "not JSON");
    expect_malformed(plan_doc(""), "paths: empty");
    expect_malformed(R"({"format": "airmass-compare-plan", "job_format": "j", "paths": []})",
                     "no field \"job_schema_version\"");
    expect_malformed(plan_doc(path_doc("a", "blender", "1") + "," + path_doc("a", "blender", "2")),
                     "paths[1]: the name a is given twice");
    expect_malformed(plan_doc(path_doc("a", "cycles", "1")), "renderer cycles is not blender or povray");
    expect_malformed(plan_doc(path_doc("a", "blender", "3")), "\"addon_flag\" is not null or a power of two");
    expect_malformed(plan_doc(path_doc("a", "blender", "null")), "a: \"addon_flag\" must be set for a blender path");
    expect_malformed(plan_doc(path_doc("a", "blender", "1") + "," + path_doc("b", "blender", "1")),
                     "b: \"addon_flag\" 1 is given twice");
    std::string no_title = path_doc("a", "blender", "1");
    no_title.replace(no_title.find(R"("title": "T", )"), 14, "");
    expect_malformed(plan_doc(no_title), "paths[0]: no field \"title\"");
    std::string bad_cost = path_doc("a", "blender", "1");
    bad_cost.replace(bad_cost.find("1.0"), 3, "\"fast\"");
    expect_malformed(plan_doc(bad_cost), "paths[0]: field \"step_cost\" has the wrong type");
    std::string bad_native = path_doc("a", "blender", "1");
    bad_native.replace(bad_native.find("[]"), 2, R"(["native_everything"])");
    expect_malformed(plan_doc(bad_native), "a: natives: native_everything is not a native render");
}

}  // namespace
