// Multiple-scattering tables as bytes (table_store.hpp): the key, the record format and its
// checks. Record layout (this machine's byte order; a record from another order fails the
// magic check):
//
//   magic "AMSTBL\0\0" | u32 format | u32 byte-order mark 0x01020304
//   u64 key length | key bytes | zero bytes to a multiple of 8
//   u64 payload length | u64 checksum of the payload (payload_checksum) | payload
//
// The payload is the fields of MultipleScattering in declaration order, each vector as a u64
// count and its elements. Every field's size is a multiple of 4 bytes and the payload starts at
// a multiple of 8 of the record, so a record read to an aligned address (a heap buffer, a
// mapped file) has every vector's elements aligned: G is used where it lies when the caller
// keeps the bytes alive (deserialize_tables' owner), the other arrays are copied at once.
#include "airmass/table_store.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "airmass/version.hpp"

namespace airmass {

namespace detail {
// A digest of the library's sources, generated at build time (plugin/CMakeLists.txt).
extern const char* const kSourceDigest;
}  // namespace detail

namespace {

constexpr char kMagic[8] = {'A', 'M', 'S', 'T', 'B', 'L', 0, 0};
// 2: MsOrderInfo::tail_corrected_change; 3: repeats_after_order; 4: the key padded to a multiple
// of 8, payload_checksum (four lanes) instead of fnv1a64; 5: order 1's own ray samples (the key
// changes with them; the format, because the values of every table do).
constexpr std::uint32_t kFormat = 5;
constexpr std::uint32_t kByteOrderMark = 0x01020304u;

class Writer {
public:
    template <class T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        const auto* p = reinterpret_cast<const std::byte*>(&v);
        bytes_.insert(bytes_.end(), p, p + sizeof(T));
    }
    void put_bytes(const void* data, std::size_t n) {
        const auto* p = static_cast<const std::byte*>(data);
        bytes_.insert(bytes_.end(), p, p + n);
    }
    void put_string(std::string_view s) {
        put<std::uint64_t>(s.size());
        put_bytes(s.data(), s.size());
    }
    template <class T>
    void put_vector(const std::vector<T>& v) {
        put<std::uint64_t>(v.size());
        put_bytes(v.data(), v.size() * sizeof(T));
    }
    std::vector<std::byte>& bytes() { return bytes_; }

private:
    std::vector<std::byte> bytes_;
};

// Writes a record's payload as TableRecord pieces: small fields copied into owned chunks, large
// arrays referenced where they lie (TableRecord::pieces).
class PieceWriter {
public:
    explicit PieceWriter(TableRecord& record) : record_(record) { record_.owned.emplace_back(); }
    template <class T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        const auto* p = reinterpret_cast<const std::byte*>(&v);
        chunk().insert(chunk().end(), p, p + sizeof(T));
    }
    template <class V>  // std::vector<T> or SharedFloats
    void put_vector(const V& v) {
        using T = typename V::value_type;
        put<std::uint64_t>(v.size());
        const std::size_t n = v.size() * sizeof(T);
        if (n < kBorrowFrom) {
            const auto* p = reinterpret_cast<const std::byte*>(v.data());
            if (n > 0) chunk().insert(chunk().end(), p, p + n);
            return;
        }
        close_chunk();
        record_.pieces.emplace_back(reinterpret_cast<const std::byte*>(v.data()), n);
    }
    // Ends the last chunk; the pieces are complete.
    void finish() { close_chunk(); }

private:
    static constexpr std::size_t kBorrowFrom = 4096;
    std::vector<std::byte>& chunk() { return record_.owned.back(); }
    void close_chunk() {
        if (chunk().empty()) return;
        record_.pieces.emplace_back(chunk().data(), chunk().size());
        record_.owned.emplace_back();  // a deque: the closed chunk's bytes stay where they are
    }
    TableRecord& record_;
};

class Reader {
public:
    explicit Reader(std::span<const std::byte> b) : bytes_(b) {}
    template <class T>
    bool get(T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        if (bytes_.size() - pos_ < sizeof(T)) return false;
        std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
        pos_ += sizeof(T);
        return true;
    }
    bool get_span(std::size_t n, std::span<const std::byte>& out) {
        if (bytes_.size() - pos_ < n) return false;
        out = bytes_.subspan(pos_, n);
        pos_ += n;
        return true;
    }
    template <class T>
    bool get_vector(std::vector<T>& v) {
        std::uint64_t n = 0;
        if (!get(n) || n > (bytes_.size() - pos_) / sizeof(T)) return false;
        const std::byte* p = bytes_.data() + pos_;
        if (reinterpret_cast<std::uintptr_t>(p) % alignof(T) == 0) {
            // One pass: the elements copied into new storage (resize would first zero it).
            const T* first = reinterpret_cast<const T*>(p);
            v.clear();
            v.reserve(std::size_t(n));
            v.assign(first, first + std::size_t(n));
        } else {
            v.resize(std::size_t(n));
            // memcpy from/to a null pointer is undefined even for 0 bytes (an empty vector's data();
            // UBSan in the sanitizer stage, TableStore.RecordRoundTripsBitForBit)
            if (n > 0) std::memcpy(v.data(), p, std::size_t(n) * sizeof(T));
        }
        pos_ += std::size_t(n) * sizeof(T);
        return true;
    }
    // An array of floats read in place when `owner` keeps the bytes alive and they are aligned
    // (a mapped cache entry: no copy, no fresh pages), else copied.
    bool get_shared(SharedFloats& v, const std::shared_ptr<const void>& owner) {
        std::uint64_t n = 0;
        if (!get(n) || n > (bytes_.size() - pos_) / sizeof(float)) return false;
        const std::byte* p = bytes_.data() + pos_;
        if (owner && reinterpret_cast<std::uintptr_t>(p) % alignof(float) == 0) {
            v = SharedFloats(reinterpret_cast<const float*>(p), std::size_t(n), owner);
            pos_ += std::size_t(n) * sizeof(float);
            return true;
        }
        pos_ -= sizeof n;  // get_vector reads the count itself
        std::vector<float> copy;
        if (!get_vector(copy)) return false;
        v = SharedFloats(std::move(copy));
        return true;
    }
    bool at_end() const { return pos_ == bytes_.size(); }

private:
    std::span<const std::byte> bytes_;
    std::size_t pos_ = 0;
};

}  // namespace

std::uint64_t fnv1a64(std::span<const std::byte> bytes) {
    // FNV-1a over 64-bit words (then the tail byte by byte): a checksum of a 40 MB table in
    // ≈ 5 ms rather than 40; it detects corruption, it is not a cryptographic hash.
    std::uint64_t h = 0xcbf29ce484222325ull;
    std::size_t i = 0;
    for (; i + 8 <= bytes.size(); i += 8) {
        std::uint64_t word;
        std::memcpy(&word, bytes.data() + i, 8);
        h ^= word;
        h *= 0x100000001b3ull;
        h ^= h >> 29;
    }
    for (; i < bytes.size(); ++i) {
        h ^= std::uint64_t(bytes[i]);
        h *= 0x100000001b3ull;
    }
    return h;
}

std::uint64_t fnv1a64(std::string_view text) {
    return fnv1a64(std::as_bytes(std::span<const char>(text.data(), text.size())));
}

namespace {

// The records' checksum: fnv1a64's word step in four independent lanes over 32-byte blocks
// (the lanes' multiplications overlap: ≈ 4× its speed, a 10 MB table in well under a
// millisecond), the lanes and the tail folded in by the same step. It detects corruption; it
// is not a cryptographic hash. Fed in pieces of any sizes, it gives the value of the bytes
// joined (a record is written from its pieces, read back whole).
class PayloadChecksum {
public:
    void update(std::span<const std::byte> bytes) {
        size_ += bytes.size();
        if (bytes.empty()) return;  // (memcpy from an empty span's null data is undefined)
        if (held_ > 0) {  // complete the block begun by the last piece
            const std::size_t n = std::min(bytes.size(), std::size_t(32) - held_);
            std::memcpy(block_ + held_, bytes.data(), n);
            held_ += n;
            bytes = bytes.subspan(n);
            if (held_ < 32) return;
            blocks(std::span<const std::byte>(block_, 32));
            held_ = 0;
        }
        const std::size_t whole = bytes.size() / 32 * 32;
        blocks(bytes.first(whole));
        held_ = bytes.size() - whole;
        if (held_ > 0) std::memcpy(block_, bytes.data() + whole, held_);
    }
    std::uint64_t value() const {
        std::uint64_t h = step(step(step(step(0xcbf29ce484222325ull, lane_[0]), lane_[1]), lane_[2]), lane_[3]);
        h = step(h, std::uint64_t(size_));
        for (std::size_t i = 0; i < held_; ++i) h = step(h, std::uint64_t(block_[i]));
        return h;
    }

private:
    static std::uint64_t step(std::uint64_t h, std::uint64_t word) {
        h ^= word;
        h *= 0x100000001b3ull;
        return h ^ (h >> 29);
    }
    void blocks(std::span<const std::byte> bytes) {
        std::uint64_t lane[4] = {lane_[0], lane_[1], lane_[2], lane_[3]};
        for (std::size_t i = 0; i + 32 <= bytes.size(); i += 32) {
            std::uint64_t w[4];
            std::memcpy(w, bytes.data() + i, 32);
            for (int l = 0; l < 4; ++l) lane[l] = step(lane[l], w[l]);
        }
        std::memcpy(lane_, lane, sizeof lane);
    }
    std::uint64_t lane_[4] = {0xcbf29ce484222325ull, 0x84222325cbf29ce4ull, 0x9e3779b97f4a7c15ull,
                              0xc2b2ae3d27d4eb4full};
    std::byte block_[32] = {};
    std::size_t held_ = 0;
    std::size_t size_ = 0;
};

std::uint64_t payload_checksum(std::span<const std::byte> bytes) {
    PayloadChecksum c;
    c.update(bytes);
    return c.value();
}

constexpr std::size_t padding_to_8(std::size_t n) { return (8 - n % 8) % 8; }

}  // namespace

std::string ms_table_key(const Atmosphere& atm, const MsSettings& s) {
    Writer w;
    w.put_string("airmass multiple-scattering tables");
    w.put_string(version_string());
    w.put_string(detail::kSourceDigest);
    // The atmosphere, as precompute_multiple_scattering reads it (not E_sun: the tables are
    // per unit irradiance; not the view-ray knobs).
    w.put(atm.planet_radius_m);
    w.put(atm.top_altitude_m);
    w.put(atm.ground_albedo);
    w.put(static_cast<std::int32_t>(atm.settings.chapman));
    w.put(static_cast<std::uint8_t>(atm.settings.ground));
    w.put_vector(atm.wavelengths_nm);
    w.put<std::uint64_t>(atm.constituents.size());
    for (const AtmosphereConstituent& c : atm.constituents) {
        const CompiledProfile& p = c.profile;
        w.put(static_cast<std::int32_t>(p.kind));
        w.put(p.scale_height_m);
        w.put(p.reference_altitude_m);
        w.put(static_cast<std::uint8_t>(p.truncate_at_top));
        w.put_vector(p.altitude_m);
        w.put_vector(p.density);
        w.put(static_cast<std::int32_t>(c.phase.kind));
        w.put(c.phase.g);
        w.put(static_cast<std::uint8_t>(c.rayleigh_like));
        w.put(static_cast<std::uint8_t>(c.scatters));
        w.put_vector(c.scattering_per_m);
        w.put_vector(c.absorption_per_m);
    }
    // The table settings that change values.
    w.put(static_cast<std::int32_t>(s.mode));
    w.put(static_cast<std::int32_t>(s.parameterisation));
    w.put(s.table);
    w.put(s.max_order);
    w.put(s.tolerance);
    w.put(s.max_auto_order);
    w.put(static_cast<std::uint8_t>(s.geometric_tail));
    w.put(s.ray_samples);
    w.put(s.order1_ray_samples);
    w.put(s.transmittance_altitude);
    w.put(s.transmittance_sun);
    w.put(s.phase_subsamples);
    const std::vector<std::byte>& b = w.bytes();
    return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

std::size_t TableRecord::size() const {
    std::size_t n = 0;
    for (const auto& p : pieces) n += p.size();
    return n;
}

TableRecord table_record(const MultipleScattering& ms, std::string_view key) {
    // The payload first (the header holds its length and checksum), then the header in front.
    TableRecord payload;
    PieceWriter p(payload);
    p.put(static_cast<std::int32_t>(ms.mode));
    p.put(static_cast<std::int32_t>(ms.grid.parameterisation));
    p.put(ms.grid.size);
    p.put(ms.grid.planet_radius_m);
    p.put(ms.grid.top_radius_m);
    p.put(ms.grid.mu_s_min);
    p.put<std::uint64_t>(ms.wavelength_count);
    p.put(ms.ground_albedo);
    p.put_vector(ms.slot);
    p.put<std::uint64_t>(ms.slot_count);
    p.put_vector(ms.phase_radiance);
    p.put_vector(ms.ground_irradiance);
    p.put_vector(ms.radiance);
    p.put<std::uint64_t>(ms.orders.size());
    for (const MsOrderInfo& o : ms.orders) {
        p.put(o.order);
        p.put_vector(o.relative);
        p.put(o.max_relative);
        p.put(o.tail_corrected_change);
    }
    p.put(ms.highest_order);
    p.put(ms.repeats_after_order);
    p.put(static_cast<std::uint8_t>(ms.tail_added));
    p.put_vector(ms.tail_ratio);
    p.put(ms.precompute_seconds);
    p.finish();
    PayloadChecksum checksum;
    for (const auto& piece : payload.pieces) checksum.update(piece);

    Writer r;
    r.put_bytes(kMagic, sizeof kMagic);
    r.put(kFormat);
    r.put(kByteOrderMark);
    r.put_string(key);
    r.put_bytes(std::array<std::byte, 8>{}.data(), padding_to_8(r.bytes().size()));
    r.put<std::uint64_t>(payload.size());
    r.put(checksum.value());
    TableRecord record;
    record.owned = std::move(payload.owned);  // a deque's move keeps its elements where they are
    record.owned.push_back(std::move(r.bytes()));
    record.pieces.emplace_back(record.owned.back().data(), record.owned.back().size());
    record.pieces.insert(record.pieces.end(), payload.pieces.begin(), payload.pieces.end());
    return record;
}

std::vector<std::byte> serialize_tables(const MultipleScattering& ms, std::string_view key) {
    const TableRecord record = table_record(ms, key);
    std::vector<std::byte> bytes;
    bytes.reserve(record.size());
    for (const auto& piece : record.pieces) bytes.insert(bytes.end(), piece.begin(), piece.end());
    return bytes;
}

std::optional<MultipleScattering> deserialize_tables(std::span<const std::byte> bytes, std::string_view key,
                                                     std::shared_ptr<const void> owner) {
    Reader r(bytes);
    std::span<const std::byte> magic, stored_key, payload;
    std::uint32_t format = 0, mark = 0;
    std::uint64_t key_size = 0, payload_size = 0, checksum = 0;
    if (!r.get_span(sizeof kMagic, magic) || std::memcmp(magic.data(), kMagic, sizeof kMagic) != 0) return {};
    if (!r.get(format) || format != kFormat || !r.get(mark) || mark != kByteOrderMark) return {};
    if (!r.get(key_size) || key_size != key.size() || !r.get_span(std::size_t(key_size), stored_key) ||
        std::memcmp(stored_key.data(), key.data(), key.size()) != 0)
        return {};
    std::span<const std::byte> padding;
    if (!r.get_span(padding_to_8(sizeof kMagic + 2 * sizeof(std::uint32_t) + sizeof key_size + key.size()), padding) ||
        std::any_of(padding.begin(), padding.end(), [](std::byte b) { return b != std::byte{0}; }))
        return {};
    if (!r.get(payload_size) || !r.get(checksum) || !r.get_span(std::size_t(payload_size), payload) || !r.at_end() ||
        payload_checksum(payload) != checksum)
        return {};

    Reader p(payload);
    MultipleScattering ms;
    std::int32_t mode = 0, parameterisation = 0;
    std::uint64_t nw = 0, slot_count = 0, order_count = 0;
    std::uint8_t tail = 0;
    bool ok = p.get(mode) && p.get(parameterisation) && p.get(ms.grid.size) && p.get(ms.grid.planet_radius_m) &&
              p.get(ms.grid.top_radius_m) && p.get(ms.grid.mu_s_min) && p.get(nw) && p.get(ms.ground_albedo) &&
              p.get_vector(ms.slot) && p.get(slot_count) && p.get_shared(ms.phase_radiance, owner) &&
              p.get_vector(ms.ground_irradiance) && p.get_vector(ms.radiance) && p.get(order_count) &&
              order_count <= 100000;
    for (std::uint64_t k = 0; ok && k < order_count; ++k) {
        MsOrderInfo o;
        ok = p.get(o.order) && p.get_vector(o.relative) && p.get(o.max_relative) && p.get(o.tail_corrected_change);
        ms.orders.push_back(std::move(o));
    }
    ok = ok && p.get(ms.highest_order) && p.get(ms.repeats_after_order) && p.get(tail) && p.get_vector(ms.tail_ratio) &&
         p.get(ms.precompute_seconds) && p.at_end();
    if (!ok || mode < 0 || mode > int(MsMode::isotropic_lut) || parameterisation < 0 ||
        parameterisation > int(MsParameterisation::seed004))
        return {};
    ms.mode = static_cast<MsMode>(mode);
    ms.grid.parameterisation = static_cast<MsParameterisation>(parameterisation);
    ms.wavelength_count = std::size_t(nw);
    ms.slot_count = std::size_t(slot_count);
    ms.tail_added = tail != 0;
    // The table sizes must agree with the grid and counts they claim (a record that passed
    // its checksum but was written by a broken writer is still not trusted).
    const std::size_t nodes = ms.mode == MsMode::orders
                                  ? ms.grid.node_count()
                                  : std::size_t(ms.grid.size.altitude) * ms.grid.size.sun_zenith;
    const std::size_t g_size = ms.slot_count == 0 ? 1 : nodes * ms.slot_count * ms.wavelength_count;
    if (ms.phase_radiance.size() != g_size ||
        ms.ground_irradiance.size() != std::size_t(ms.grid.size.sun_zenith) * ms.wavelength_count)
        return {};
    for (int s : ms.slot)
        if (s < -1 || s >= int(ms.slot_count)) return {};
    return ms;
}

}  // namespace airmass
