// Loads tests/data/chapman_reference.csv (mpmath, 45 digits; scripts/gen_chapman_reference.py).
#pragma once

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace airmass::test {

struct ChapmanReference {
    double x, chi_deg, ln_ch;
};

inline std::vector<ChapmanReference> load_chapman_reference() {
    std::vector<ChapmanReference> rows;
    std::ifstream f(std::string(AIRMASS_TEST_DATA_DIR) + "/chapman_reference.csv");
    std::string line;
    while (std::getline(f, line)) {
        if (line.empty() || line[0] == '#' || line[0] == 'x') continue;
        std::stringstream ss(line);
        std::string x, chi, ch, ln;
        std::getline(ss, x, ',');
        std::getline(ss, chi, ',');
        std::getline(ss, ch, ',');
        std::getline(ss, ln, ',');
        rows.push_back({std::strtod(x.c_str(), nullptr), std::strtod(chi.c_str(), nullptr),
                        std::strtod(ln.c_str(), nullptr)});
    }
    return rows;
}

}  // namespace airmass::test
