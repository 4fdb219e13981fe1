// Multiple-scattering tables kept between runs: their identity (a key), their bytes, and the
// interface of a place that keeps them.
//
// The tables depend on the compiled atmosphere and the table settings only — not on the sun,
// the observer or the image — so a host that renders the same atmosphere again (the CLI run
// after run, the add-on while the sun is dragged) need not compute them again. The library
// writes no files: it turns tables into bytes and back; a host decides where they live
// (the CLI's disk cache, airmass/table_cache.hpp; the add-on keeps them in memory).
//
// The key holds everything `precompute_multiple_scattering` reads — the atmosphere's
// geometry, ground albedo, wavelengths, every constituent's profile, phase and coefficients,
// the Chapman method and the ground switch, the table settings that change values — plus the
// library's version and a digest of its sources at build time, so a changed library never
// reads an older library's tables. Bytes whose key differs in any bit, whose checksum fails
// or whose length is wrong are rejected (never trusted), and the caller computes afresh.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/multiple_scattering.hpp"

namespace airmass {

// Canonical bytes identifying the tables of `atmosphere` under `settings` (threads, progress,
// cancel and keep_radiance's diagnostics excluded: they do not change G or E_ms).
std::string ms_table_key(const Atmosphere& atmosphere, const MsSettings& settings);

// A 64-bit FNV-1a-style hash of bytes, over 64-bit words (a file name for a key and the
// records' checksum; the key itself is compared in full).
std::uint64_t fnv1a64(std::span<const std::byte> bytes);
std::uint64_t fnv1a64(std::string_view text);

// The tables a renderer needs (G or Ψ, E_ms, the grid, slots, order information), with `key`
// and a checksum, in this machine's byte order.
std::vector<std::byte> serialize_tables(const MultipleScattering& tables, std::string_view key);

// The same record as pieces to be written one after the other: the header and the small
// fields held in `owned`, every array of 4 kB or more (G; E_ms from 43 wavelengths on)
// referenced where it lies in `tables` — nothing of a 10 MB table is copied before it reaches
// the file. Valid while `tables` lives and is not changed. Move-only: `pieces` point into
// `owned`, which a copy would not own.
struct TableRecord {
    std::vector<std::span<const std::byte>> pieces;
    std::deque<std::vector<std::byte>> owned;
    std::size_t size() const;

    TableRecord() = default;
    TableRecord(TableRecord&&) = default;
    TableRecord& operator=(TableRecord&&) = default;
    TableRecord(const TableRecord&) = delete;
    TableRecord& operator=(const TableRecord&) = delete;
};
TableRecord table_record(const MultipleScattering& tables, std::string_view key);

// The tables in `bytes` if they are a whole, uncorrupted record of this format with exactly
// `key`; std::nullopt otherwise (foreign, truncated, corrupt, older format). With an `owner`
// that keeps `bytes` alive and unchanged (a mapped file), the G table is read in place — the
// tables then share that memory (SharedFloats) — else every array is copied.
std::optional<MultipleScattering> deserialize_tables(std::span<const std::byte> bytes, std::string_view key,
                                                     std::shared_ptr<const void> owner = {});

// Where a host keeps tables between calls. Both calls are made from the thread that asks for
// the tables; neither may throw for a missing, unreadable or unwritable entry (a store that
// fails simply does not keep: the tables are computed).
class TableStore {
public:
    virtual ~TableStore() = default;
    // The tables stored under `key`, or null.
    virtual std::shared_ptr<const MultipleScattering> load(std::string_view key) = 0;
    // Keep `tables` under `key` (replacing any entry).
    virtual void store(std::string_view key, const MultipleScattering& tables) = 0;
};

}  // namespace airmass
