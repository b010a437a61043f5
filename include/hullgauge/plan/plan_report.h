// Writing a view plan: plan.json (docs/contracts.md §5 `hullgauge plan`), a poses file
// for `hullgauge simulate` and the capture sequence (docs/contracts.md §5 poses
// format), and a Markdown report for the designer. Format: docs/planning.md.
#pragma once

#include "hullgauge/plan/planner.h"

#include <nlohmann/json.hpp>
#include <string>

namespace hg::plan {

/// plan.json: views with fixture pose, K, dist, R, t, the landmarks each view
/// observes with their predicted MED; per landmark its verdict, the views
/// observing it, witnesses, and for one that is not inspectable the reason,
/// blocker and nearest inspectable point; the type-four voids to pare.
nlohmann::json planToJson(const ViewPlan& plan, const PlanProblem& problem);

/// The planned views as a poses YAML list, in travel order.
std::string posesYaml(const ViewPlan& plan, FixtureType type);

/// A readable report: summary, views, landmarks, problems and warnings.
std::string planMarkdown(const ViewPlan& plan, const PlanProblem& problem);

} // namespace hg::plan
