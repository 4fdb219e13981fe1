// Google Benchmark's console report, with one number kept per benchmark for the ratios a bench
// prints after its runs (each against a baseline measured in the same run): the median of the
// repetitions where there are repetitions, else the run itself.
#pragma once

#include <benchmark/benchmark.h>

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace airmass::bench {

class RunTimes : public benchmark::ConsoleReporter {
public:
    // The number kept for a run (ns per point, ms per precompute, ...); not > 0: not kept.
    using Measure = std::function<double(const Run&)>;
    explicit RunTimes(Measure measure) : measure_(std::move(measure)) {}

    void ReportRuns(const std::vector<Run>& runs) override {
        ConsoleReporter::ReportRuns(runs);
        for (const auto& run : runs) {
            const double v = measure_(run);
            if (!(v > 0)) continue;
            const std::string name = run.benchmark_name();
            if (run.run_type == Run::RT_Aggregate && run.aggregate_name == "median")
                median_[name.substr(0, name.size() - std::string("_median").size())] = v;
            else if (run.run_type == Run::RT_Iteration)
                single_.emplace(name, v);  // the first repetition, used only without a median
        }
    }

    // Every benchmark's number by name.
    std::map<std::string, double> all() const {
        auto r = single_;
        for (const auto& [k, v] : median_) r[k] = v;
        return r;
    }
    // One benchmark's number, or -1 if it did not run.
    double get(const std::string& name) const {
        const auto r = all();
        const auto it = r.find(name);
        return it == r.end() ? -1.0 : it->second;
    }
    // The first (by name) benchmark whose name starts with `prefix`, or -1.
    double first_with_prefix(const std::string& prefix) const {
        for (const auto& [name, v] : all())
            if (name.rfind(prefix, 0) == 0) return v;
        return -1.0;
    }

private:
    Measure measure_;
    std::map<std::string, double> single_, median_;
};

}  // namespace airmass::bench
