// SpectralTableView (airmass/spectral_table.hpp): node layout, multilinear lookup against a
// function it must reproduce exactly (multilinear in the node coordinates), degenerate axes,
// the offset of one spectrum among several per node, and the size check.
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "airmass/spectral_table.hpp"

namespace {

using airmass::SpectralTableView;
using airmass::TableCoord;
using airmass::table_coord;

TEST(SpectralTable, IndexIsRowMajorWithChannelsInnermost) {
    std::vector<float> v(2 * 3 * 4 * 5);
    const SpectralTableView<float, 3> t(v, {2, 3, 4}, 5);
    EXPECT_EQ(t.node_count(), 24u);
    EXPECT_EQ(t.index({0, 0, 0}), 0u);
    EXPECT_EQ(t.index({0, 0, 1}), 5u);
    EXPECT_EQ(t.index({0, 1, 0}), 20u);
    EXPECT_EQ(t.index({1, 2, 3}), ((1u * 3 + 2) * 4 + 3) * 5);
    t.at({1, 2, 3})[4] = 7.0f;
    EXPECT_EQ(v.back(), 7.0f);
    EXPECT_EQ(t.at({1, 0, 0}, 2, 3).data(), v.data() + 60 + 2);
}

TEST(SpectralTable, CoordinatesClampAndKeepTheUpperNodeInRange) {
    EXPECT_EQ(table_coord(-1.0, 0, 4).i0, 0);
    EXPECT_EQ(table_coord(-1.0, 0, 4).f, 0.0f);
    EXPECT_EQ(table_coord(4.0, 0, 4).i0, 3);  // the last node: lower node 3, fraction 1
    EXPECT_EQ(table_coord(4.0, 0, 4).f, 1.0f);
    EXPECT_EQ(table_coord(2.25, 0, 4).i0, 2);
    EXPECT_EQ(table_coord(2.25, 0, 4).f, 0.25f);
    EXPECT_EQ(table_coord(9.0, 5, 5).i0, 5);  // one node
    EXPECT_EQ(table_coord(9.0, 5, 5).f, 0.0f);
}

// f(i, j, k; c) = (c + 1)(1 + 2i − 3j + 0.5k + i·j): multilinear, so the lookup is exact up to
// rounding (values are small integers and halves, fractions quarters: exact in double).
TEST(SpectralTable, LookupReproducesAMultilinearFunction) {
    const int ni = 3, nj = 4, nk = 2;
    const std::size_t nc = 3;
    std::vector<double> v(std::size_t(ni) * nj * nk * nc);
    const SpectralTableView<double, 3> t(v, {ni, nj, nk}, nc);
    const auto f = [](double i, double j, double k, std::size_t c) {
        return double(c + 1) * (1 + 2 * i - 3 * j + 0.5 * k + i * j);
    };
    for (int i = 0; i < ni; ++i)
        for (int j = 0; j < nj; ++j)
            for (int k = 0; k < nk; ++k)
                for (std::size_t c = 0; c < nc; ++c) t.at({i, j, k})[c] = f(i, j, k, c);
    std::vector<double> out(nc);
    for (double i : {0.0, 0.25, 1.5, 2.0})
        for (double j : {0.0, 0.75, 2.5, 3.0})
            for (double k : {0.0, 0.5, 1.0}) {
                t.lookup({table_coord(i, 0, ni - 1), table_coord(j, 0, nj - 1), table_coord(k, 0, nk - 1)}, out);
                for (std::size_t c = 0; c < nc; ++c) EXPECT_EQ(out[c], f(i, j, k, c)) << i << " " << j << " " << k;
            }
}

TEST(SpectralTable, DegenerateAxisAndOffsetReadOneSpectrum) {
    // shape {2, 1}: the second axis has one node (its upper corner has weight 0 and is not read);
    // two spectra of 2 wavelengths per node, read the second (offset 2).
    std::vector<float> v{1, 2, 10, 20, /* node 1: */ 3, 4, 30, 40};
    const SpectralTableView<const float, 2> t(v, {2, 1}, 4);
    std::vector<float> out(2);
    t.lookup({TableCoord{0, 0.5f}, table_coord(0.7, 0, 0)}, out, 2);
    EXPECT_EQ(out[0], 20.0f);
    EXPECT_EQ(out[1], 30.0f);
    // double output from a float table
    std::vector<double> outd(2);
    t.lookup({TableCoord{0, 0.25f}, TableCoord{0, 0.0f}}, outd);
    EXPECT_EQ(outd[0], 1.5);
    EXPECT_EQ(outd[1], 2.5);
}

TEST(SpectralTable, WrongSizeThrowsNamingTheSizes) {
    std::vector<float> v(10);
    try {
        const SpectralTableView<float, 2> t(v, {2, 3}, 2);
        FAIL() << "no exception";
    } catch (const std::length_error& e) {
        EXPECT_STREQ(e.what(), "spectral table: 10 values for 6 nodes × 2 channels");
    }
}

}  // namespace
