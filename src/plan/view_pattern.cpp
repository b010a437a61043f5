#include "hullgauge/plan/view_pattern.h"

#include <algorithm>
#include <climits>
#include <glpk.h>
#include <iterator>
#include <map>

namespace hg::plan {

PoseSet intersect(const PoseSet& a, const PoseSet& b)
{
    PoseSet out;
    std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
    return out;
}

std::size_t intersectionSize(const PoseSet& a, const PoseSet& b)
{
    std::size_t n = 0;
    auto i = a.begin();
    auto j = b.begin();
    while (i != a.end() && j != b.end()) {
        if (*i < *j)
            ++i;
        else if (*j < *i)
            ++j;
        else {
            ++n;
            ++i;
            ++j;
        }
    }
    return n;
}

namespace {

struct View {
    PoseSet variation;
    std::vector<std::size_t> requirements;
    std::size_t orGroup = 0; // the requirement whose OR list it belongs to (phase 1)
    bool alive = true;
};

} // namespace

GreedyResult greedyViewPattern(const std::vector<Requirement>& requirements, const PatternOptions& options)
{
    GreedyResult result;
    std::vector<View> views;
    std::vector<std::size_t> remaining(requirements.size(), 0); // live sub-views per requirement
    for (std::size_t r = 0; r < requirements.size(); ++r) {
        for (const auto& sub : requirements[r].anyOf)
            if (!sub.empty()) {
                views.push_back({sub, {r}, r, true});
                ++remaining[r];
            }
        if (remaining[r] == 0) result.unserved.push_back(r);
    }

    // Phase 1 (fig. 5.24): OR redundancy removal, largest intersection first so
    // that an early choice from one OR list does not spoil a better match later.
    auto dropSiblings = [&](std::size_t keep) {
        for (auto& v : views)
            if (&v != &views[keep] && v.alive && v.orGroup == views[keep].orGroup) v.alive = false;
        remaining[views[keep].orGroup] = 1;
    };
    for (;;) {
        std::size_t bestA = views.size();
        std::size_t bestSize = 0;
        bool any = false;
        for (std::size_t a = 0; a < views.size(); ++a) {
            if (!views[a].alive || remaining[views[a].orGroup] <= 1) continue;
            any = true;
            for (std::size_t b = 0; b < views.size(); ++b) {
                if (!views[b].alive || views[b].orGroup == views[a].orGroup) continue;
                const std::size_t s = intersectionSize(views[a].variation, views[b].variation);
                if (s > bestSize || (s == bestSize && s > 0 && bestA < views.size() &&
                                     views[a].variation.size() > views[bestA].variation.size())) {
                    bestSize = s;
                    bestA = a;
                }
            }
        }
        if (!any) break;
        if (bestSize == 0) {
            // No OR sub-view meets any other view: keep each list's widest sub-view.
            for (std::size_t a = 0; a < views.size(); ++a) {
                if (!views[a].alive || remaining[views[a].orGroup] <= 1) continue;
                std::size_t widest = a;
                for (std::size_t b = a + 1; b < views.size(); ++b)
                    if (views[b].alive && views[b].orGroup == views[a].orGroup &&
                        views[b].variation.size() > views[widest].variation.size())
                        widest = b;
                dropSiblings(widest);
            }
            break;
        }
        dropSiblings(bestA);
    }

    // Phase 2 (fig. 5.18): AND combination by largest intersection.
    std::vector<std::size_t> live;
    for (std::size_t i = 0; i < views.size(); ++i)
        if (views[i].alive) live.push_back(i);
    const std::size_t n = live.size();
    std::vector<std::size_t> inter(n * n, 0);
    auto at = [&](std::size_t i, std::size_t j) -> std::size_t& { return inter[i * n + j]; };
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j)
            at(i, j) = at(j, i) = intersectionSize(views[live[i]].variation, views[live[j]].variation);
    const std::size_t threshold = std::max<std::size_t>(1, options.minIntersection);
    for (;;) {
        std::size_t bi = n, bj = n, best = 0;
        for (std::size_t i = 0; i < n; ++i) {
            if (!views[live[i]].alive) continue;
            for (std::size_t j = i + 1; j < n; ++j)
                if (views[live[j]].alive && at(i, j) > best) {
                    best = at(i, j);
                    bi = i;
                    bj = j;
                }
        }
        if (best < threshold) break;
        View& a = views[live[bi]];
        View& b = views[live[bj]];
        a.variation = intersect(a.variation, b.variation);
        a.requirements.insert(a.requirements.end(), b.requirements.begin(), b.requirements.end());
        b.alive = false;
        for (std::size_t k = 0; k < n; ++k)
            if (k != bi && views[live[k]].alive)
                at(bi, k) = at(k, bi) = intersectionSize(a.variation, views[live[k]].variation);
    }

    for (std::size_t i : live) {
        if (!views[i].alive) continue;
        ViewGroup g;
        g.variation = views[i].variation;
        g.requirements = views[i].requirements;
        std::sort(g.requirements.begin(), g.requirements.end());
        for (std::size_t r : g.requirements) g.landmarks.push_back(requirements[r].landmark);
        std::sort(g.landmarks.begin(), g.landmarks.end());
        g.landmarks.erase(std::unique(g.landmarks.begin(), g.landmarks.end()), g.landmarks.end());
        result.groups.push_back(std::move(g));
    }
    return result;
}

std::vector<int> removeRedundantPoses(const std::vector<Requirement>& requirements, std::vector<int> poses)
{
    auto meets = [](const Requirement& r, int p) {
        for (const auto& sub : r.anyOf)
            if (std::binary_search(sub.begin(), sub.end(), p)) return true;
        return false;
    };
    // coverCount[r]: chosen poses meeting requirement r.
    std::vector<std::size_t> coverCount(requirements.size(), 0);
    std::vector<std::size_t> served(poses.size(), 0);
    for (std::size_t i = 0; i < poses.size(); ++i)
        for (std::size_t r = 0; r < requirements.size(); ++r)
            if (meets(requirements[r], poses[i])) {
                ++coverCount[r];
                ++served[i];
            }
    std::vector<std::size_t> order(poses.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return served[a] < served[b]; });
    std::vector<bool> keep(poses.size(), true);
    for (std::size_t i : order) {
        bool needed = false;
        for (std::size_t r = 0; r < requirements.size() && !needed; ++r)
            needed = coverCount[r] == 1 && meets(requirements[r], poses[i]);
        if (needed) continue;
        keep[i] = false;
        for (std::size_t r = 0; r < requirements.size(); ++r)
            if (meets(requirements[r], poses[i])) --coverCount[r];
    }
    std::vector<int> out;
    for (std::size_t i = 0; i < poses.size(); ++i)
        if (keep[i]) out.push_back(poses[i]);
    return out;
}

ExactResult exactViewCover(const std::vector<Requirement>& requirements, double timeLimitSeconds)
{
    ExactResult result;
    // Columns: every pose named by some requirement.
    std::map<int, int> column;
    std::vector<PoseSet> rows;
    for (const auto& req : requirements) {
        PoseSet u;
        for (const auto& sub : req.anyOf) u.insert(u.end(), sub.begin(), sub.end());
        std::sort(u.begin(), u.end());
        u.erase(std::unique(u.begin(), u.end()), u.end());
        if (u.empty()) {
            result.message = "a requirement has no candidate pose";
            return result;
        }
        for (int p : u) column.emplace(p, 0);
        rows.push_back(std::move(u));
    }
    if (rows.empty()) {
        result.solved = result.optimal = true;
        return result;
    }
    std::vector<int> poseOf;
    for (auto& [pose, col] : column) {
        poseOf.push_back(pose);
        col = static_cast<int>(poseOf.size()); // GLPK columns are 1-based
    }

    glp_term_out(GLP_OFF);
    glp_prob* lp = glp_create_prob();
    glp_set_obj_dir(lp, GLP_MIN);
    glp_add_cols(lp, static_cast<int>(poseOf.size()));
    for (int c = 1; c <= static_cast<int>(poseOf.size()); ++c) {
        glp_set_col_kind(lp, c, GLP_BV);
        glp_set_obj_coef(lp, c, 1.0);
    }
    glp_add_rows(lp, static_cast<int>(rows.size()));
    std::vector<int> ia{0}, ja{0};
    std::vector<double> ar{0.0};
    for (std::size_t r = 0; r < rows.size(); ++r) {
        glp_set_row_bnds(lp, static_cast<int>(r) + 1, GLP_LO, 1.0, 0.0);
        for (int p : rows[r]) {
            ia.push_back(static_cast<int>(r) + 1);
            ja.push_back(column[p]);
            ar.push_back(1.0);
        }
    }
    glp_load_matrix(lp, static_cast<int>(ia.size()) - 1, ia.data(), ja.data(), ar.data());

    glp_iocp parm;
    glp_init_iocp(&parm);
    parm.presolve = GLP_ON;
    parm.tm_lim = static_cast<int>(std::min(timeLimitSeconds * 1000.0, static_cast<double>(INT_MAX)));
    const int rc = glp_intopt(lp, &parm);
    const int status = glp_mip_status(lp);
    if ((rc == 0 || rc == GLP_ETMLIM) && (status == GLP_OPT || status == GLP_FEAS)) {
        result.solved = true;
        result.optimal = rc == 0 && status == GLP_OPT;
        for (std::size_t c = 0; c < poseOf.size(); ++c)
            if (glp_mip_col_val(lp, static_cast<int>(c) + 1) > 0.5) result.poses.push_back(poseOf[c]);
        if (!result.optimal) result.message = "time limit reached before optimality was proven";
    } else {
        result.message = rc == GLP_ETMLIM ? "time limit reached without a solution"
                                          : "GLPK failed (code " + std::to_string(rc) + ")";
    }
    glp_delete_prob(lp);
    return result;
}

} // namespace hg::plan
