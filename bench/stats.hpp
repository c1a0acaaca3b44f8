// SPDX-License-Identifier: Apache-2.0
// Percentiles of a sample set, for the benchmark tables.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace drivebus::bench {

struct Summary {
    std::size_t count = 0;
    double p50 = 0, p99 = 0, p999 = 0, max = 0, min = 0;
};

inline Summary summarize(std::vector<double> samples) {
    Summary s;
    s.count = samples.size();
    if (samples.empty()) {
        return s;
    }
    std::sort(samples.begin(), samples.end());
    auto at = [&](double q) {
        const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(samples.size()))) - 1;
        return samples[std::min(i, samples.size() - 1)];
    };
    s.min = samples.front();
    s.p50 = at(0.50);
    s.p99 = at(0.99);
    s.p999 = at(0.999);
    s.max = samples.back();
    return s;
}

}  // namespace drivebus::bench
