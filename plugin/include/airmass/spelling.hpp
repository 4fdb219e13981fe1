// What a person probably meant by a name the program does not know: the edit distance of two
// names, and the one rule the scene reader (an unknown or missing key, docs/scene.md) and the
// command line (an unknown option) use to call one a misspelling of the other.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string_view>
#include <vector>

namespace airmass {

// Levenshtein distance: insertions, deletions and substitutions (short names only: O(|a|·|b|)).
inline std::size_t edit_distance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

// `typed` is within one edit of `name` when the name has three letters or fewer, two otherwise.
inline bool looks_like_misspelling(std::string_view typed, std::string_view name) {
    return edit_distance(typed, name) <= (name.size() <= 3 ? 1u : 2u);
}

}  // namespace airmass
