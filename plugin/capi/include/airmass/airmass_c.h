/* airmass_c.h — the plain C ABI of libairmass_c, for hosts that cannot link C++
 * (the Blender add-on loads it with Python's ctypes; see addon/airmass_blender/native.py).
 *
 * Rules every function follows
 *   * Nothing aborts and no exception crosses this boundary: each function returns an
 *     airmass_status (0 = AIRMASS_OK) and, on failure, writes a NUL-terminated message
 *     into the caller's buffer `message` (`message_size` bytes, truncated to fit; either
 *     may be NULL/0). Messages name the field, value and allowed range, e.g.
 *     "planet.radius_km = -1: must be in (0, 1e+06]".
 *   * Versioned: AIRMASS_C_ABI_VERSION changes whenever a declaration here changes
 *     incompatibly; a host checks airmass_abi_version() before any other call. Every
 *     struct starts with `struct_size` (the caller sets sizeof, also before calling a
 *     struct's *_init function); the library refuses a size it does not know, *_init
 *     included (which then writes nothing), so old hosts and new libraries never misread
 *     each other and a host's stale mirror of a struct (ctypes) is refused, not overwritten.
 *   * Units are SI as in the C++ API (plugin/include/airmass/scene.hpp): metres, degrees,
 *     m⁻¹; except VDB lengths, which are in the chosen length unit (km by default).
 *   * Strings returned by the library (`char** out`) are allocated by it and must be
 *     released with airmass_string_free().
 *   * Long calls (sky, VDB) run their work on a library thread while the calling thread
 *     reports progress: `progress(user, fraction)` is always called on the CALLING thread
 *     (so a Python callback may touch Python state), at most every ~50 ms and once with
 *     1.0 at the end; a nonzero return requests cancellation. A cancel token (below) can
 *     also be set from any thread (the library only reads it, so a token can be reused
 *     after airmass_cancel_token_reset). A cancelled call returns AIRMASS_CANCELLED and leaves
 *     no file behind.
 *   * Thread-safe: no global mutable state; calls may run concurrently.
 */
#ifndef AIRMASS_C_H
#define AIRMASS_C_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32)
#define AIRMASS_C_API __declspec(dllexport)
#else
#define AIRMASS_C_API __attribute__((visibility("default")))
#endif

#define AIRMASS_C_ABI_VERSION 8  /* 2: airmass_sky_options.multiple_scattering
                                    3: no files: the sky and the volume grids are returned as
                                       float buffers that the host writes (Blender's image API,
                                       its own OpenVDB module); airmass_write_sky_exr and
                                       airmass_write_vdb are gone
                                    4: the *_init functions return a status and read struct_size,
                                       which the caller sets (they wrote it before): a size they
                                       do not know is refused and the struct left untouched
                                    5: airmass_solar_position (added; nothing else changed)
                                    6: sky sessions (airmass_sky_session_*: the atmosphere and its
                                       multiple-scattering tables made once, a sky per sun
                                       direction); airmass_sky_options gains multiple_grid and
                                       multiple_samples (its size differs from ABI 5's)
                                    7: airmass_sun_column_table, airmass_sun_ms_table (added;
                                       nothing else changed)
                                    8: airmass_vdb_options gains voxel_values (its size differs
                                       from ABI 7's); VDB sessions (airmass_vdb_session_*) */

typedef enum airmass_status {
    AIRMASS_OK = 0,
    AIRMASS_INVALID_ARGUMENT = 1, /* a NULL pointer, unknown struct_size, bad option string  */
    AIRMASS_SCENE_ERROR = 2,      /* the scene (file, preset or override) is invalid          */
    AIRMASS_SETTINGS_ERROR = 3,   /* sky / VDB settings out of range, or a memory limit        */
    AIRMASS_IO_ERROR = 4,         /* the output cannot be written                              */
    AIRMASS_CANCELLED = 5,        /* stopped by the progress callback or the cancel token      */
    AIRMASS_UNSUPPORTED = 6,      /* this build lacks the feature (e.g. no vdb_export)         */
    AIRMASS_INTERNAL_ERROR = 99   /* anything else (out of memory, a bug): message says what  */
} airmass_status;

/* ---- Version ------------------------------------------------------------------------- */

AIRMASS_C_API int32_t airmass_abi_version(void);         /* AIRMASS_C_ABI_VERSION         */
AIRMASS_C_API const char* airmass_version_string(void);  /* library version, e.g. "0.1.0" */
AIRMASS_C_API const char* airmass_status_name(int32_t status); /* "AIRMASS_OK", ...       */
/* 1 when the library has the volume functions ("Volumes" below: airmass_vdb_plan,
 * airmass_vdb_grid_values, airmass_analytic_density_json). The library never writes a .vdb
 * itself: the host writes the grids it returns with its own OpenVDB. */
AIRMASS_C_API int32_t airmass_has_vdb(void);

AIRMASS_C_API void airmass_string_free(char* s);

/* What this library file is, as JSON: {"version", "abi", "platform" ("linux-x64",
 * "windows-x64", "macos-arm64", ...), "simd" (the kernels this CPU runs: "avx2+fma" or
 * "baseline x86-64"), "compiler"}. For hosts' "about" boxes and bug reports. */
AIRMASS_C_API int32_t airmass_build_info(char** out, char* message, size_t message_size);

/* Newline-separated lists: preset names ("earth\nmars\n...") and Chapman methods. */
AIRMASS_C_API int32_t airmass_preset_names(char** out, char* message, size_t message_size);
AIRMASS_C_API int32_t airmass_chapman_method_names(char** out, char* message, size_t message_size);

/* ---- Scenes ---------------------------------------------------------------------------- */

/* Per-constituent overrides, matched by name (an unknown name is an error). */
typedef struct airmass_constituent_override {
    const char* name;
    int32_t enabled;        /* 0: the constituent is removed (costs nothing)            */
    double density_scale;   /* NaN: keep; ≥ 0, multiplies its scattering and absorption */
    double scale_height_m;  /* NaN: keep; exponential profiles only, > 0                */
} airmass_constituent_override;

/* Where a scene comes from, plus overrides. Exactly one of `toml` (scene text, which may
 * itself say preset = "name" and override parts of it; docs/scene.md) and `preset` is set.
 * Numeric overrides: NaN keeps the scene's value. Call airmass_scene_spec_init first. */
typedef struct airmass_scene_spec {
    uint32_t struct_size;
    const char* toml;
    const char* preset;
    const char* source_name;     /* for messages; NULL: "<scene>" / "<preset NAME>"   */
    double sun_elevation_deg;    /* [-90, 90]                                          */
    double sun_rotation_deg;     /* Blender Sky Texture rotation: 0 → +Y, 90 → +X      */
    double altitude_m;           /* observer altitude above the surface                */
    double planet_radius_m;
    double atmosphere_top_m;     /* radius of the atmosphere's top                     */
    double ground_albedo;
    int32_t basis;               /* -1 keep, 0 spectral (the scene's wavelengths, or
                                    360:830:10 nm), 1 rgb-schuler (615/535/445 nm)     */
    uint32_t constituent_count;
    const airmass_constituent_override* constituents;
    /* Camera for the VDB `view` region (has_camera = 1): scene frame, metres. */
    int32_t has_camera;
    double camera_position_m[3];
    double camera_direction[3];
    double camera_up[3];
    double camera_fov_deg;       /* horizontal (sensor fit AUTO with width ≥ height)   */
    double camera_max_distance_m;
    int32_t camera_width, camera_height;
} airmass_scene_spec;

/* Sets spec->struct_size first: spec.struct_size = sizeof spec; airmass_scene_spec_init(&spec).
 * Every *_init function returns AIRMASS_OK, or AIRMASS_INVALID_ARGUMENT (and writes nothing) for
 * NULL or a struct_size other than this library's sizeof. */
AIRMASS_C_API int32_t airmass_scene_spec_init(airmass_scene_spec* spec);

/* Parses, applies the overrides and validates. On success, and when `scene_json` is not
 * NULL, returns the resulting scene as JSON (scene_to_json) for the host's UI. */
AIRMASS_C_API int32_t airmass_validate_scene(const airmass_scene_spec* spec, char** scene_json, char* message,
                                             size_t message_size);

/* ---- Progress and cancellation ------------------------------------------------------------ */

typedef struct airmass_cancel_token airmass_cancel_token;
AIRMASS_C_API airmass_cancel_token* airmass_cancel_token_new(void);
AIRMASS_C_API void airmass_cancel_token_request(airmass_cancel_token* token); /* any thread */
AIRMASS_C_API void airmass_cancel_token_reset(airmass_cancel_token* token);
AIRMASS_C_API int32_t airmass_cancel_token_requested(const airmass_cancel_token* token);
AIRMASS_C_API void airmass_cancel_token_free(airmass_cancel_token* token);

/* Returns nonzero to request cancellation. Called on the calling thread. */
typedef int32_t (*airmass_progress_fn)(void* user, double fraction);

typedef struct airmass_job {
    uint32_t struct_size;
    airmass_progress_fn progress;  /* may be NULL */
    void* user;
    airmass_cancel_token* cancel;  /* may be NULL */
} airmass_job;

/* ---- Sky texture ---------------------------------------------------------------------------- */

typedef struct airmass_sky_options {
    uint32_t struct_size;
    int32_t width, height;  /* pixels; height 0: width / 2                              */
    int32_t view_samples;   /* samples per scattering constituent along each view ray   */
    const char* chapman;    /* method name (airmass_chapman_method_names); NULL: default */
    int32_t sun_disc;       /* 1: include the solar disc                                 */
    int32_t upper_only;     /* 1: compute only the upper hemisphere (the rest is 0)      */
    int32_t threads;        /* 0: all hardware threads                                   */
    int32_t grid;           /* sky grid intervals (sky.hpp SkySettings::grid): -1 automatic,
                               0 every pixel, N > 0 an N-interval grid interpolated per pixel */
    int32_t multiple_scattering; /* 1 (default): add multiple scattering (docs/multiple_scattering.md) */
    int32_t multiple_grid;  /* the multiple-scattering view's azimuth intervals (sky.hpp
                               SkySettings::multiple_grid, default 32): 0 integrates every ray,
                               else in [2, 16384] */
    int32_t multiple_samples; /* quadrature intervals along each multiple-scattering view ray
                               (SkySettings::multiple.view_samples, default 32), [1, 100000] */
} airmass_sky_options;

AIRMASS_C_API int32_t airmass_sky_options_init(airmass_sky_options* options); /* struct_size set first */

/* Renders the sky into the caller's buffer `rgba`: options->width × height pixels (height 0:
 * width / 2), 4 floats each (linear Rec.709 R, G, B in the sky texture's units, A = 1), rows from
 * the top (row 0 looks straight up; Blender's image pixels start at the bottom row, so the host
 * flips), Blender's equirectangular convention (docs/sky.md). `float_count` must be exactly
 * width·height·4. When `metadata_json` is not NULL it receives a JSON object of the strings an
 * EXR of this sky carries ("airmass:version", "airmass:scene", ...) for the host to store.
 * `job` may be NULL. On failure or cancel the buffer's contents are unspecified. */
AIRMASS_C_API int32_t airmass_render_sky(const airmass_scene_spec* spec, const airmass_sky_options* options,
                                         float* rgba, size_t float_count, const airmass_job* job,
                                         char** metadata_json, char* message, size_t message_size);

/* ---- Sky sessions: one atmosphere, many suns ---------------------------------------------------
 *
 * airmass_render_sky compiles the atmosphere and computes the multiple-scattering tables (about a
 * second at 48 wavelengths) on every call. Neither depends on the sun, the observer or the image,
 * so a host that renders many skies of one atmosphere (a live preview while the sun is dragged)
 * makes a session once and renders each sun with it:
 *   1. airmass_sky_session_create(spec, options, job, &session, ...): the scene (its sun and
 *      observer are only defaults for the renders), the options' chapman and
 *      multiple_scattering (fixed for the session); a long call (the tables), progress/cancel
 *      through `job` (may be NULL). The other options are the renders' defaults.
 *   2. airmass_sky_session_render(session, view, options, rgba, ...): the sky for view's sun and
 *      observer into the caller's buffer, exactly as airmass_render_sky would render it for that
 *      spec with the sun and altitude overridden (same pixels). `options` may be NULL (the
 *      session's) or differ from them in width, height, view_samples, sun_disc, upper_only,
 *      threads, grid, multiple_grid and multiple_samples (a preview quality); a different chapman or
 *      multiple_scattering is AIRMASS_SETTINGS_ERROR naming the field (make another session).
 *   3. airmass_sky_session_free(session).
 * Thread-safe: a session is immutable after create; renders of one session may run at once on
 * several threads (each needs its own buffer). Free it only when no call uses it. */

typedef struct airmass_sky_session airmass_sky_session;

/* The sun and the observer of one render. NaN (the defaults of airmass_sky_view_init): the
 * session's scene value. */
typedef struct airmass_sky_view {
    uint32_t struct_size;
    double sun_elevation_deg;  /* [-90, 90]                                       */
    double sun_rotation_deg;   /* Blender Sky Texture rotation: 0 → +Y, 90 → +X; finite */
    double altitude_m;         /* observer above the surface, [0, 1e9]              */
} airmass_sky_view;

AIRMASS_C_API int32_t airmass_sky_view_init(airmass_sky_view* view); /* struct_size set first */

/* `*out` receives the session (NULL on failure). `options` may be NULL (the defaults). */
AIRMASS_C_API int32_t airmass_sky_session_create(const airmass_scene_spec* spec, const airmass_sky_options* options,
                                                 const airmass_job* job, airmass_sky_session** out, char* message,
                                                 size_t message_size);

/* As airmass_render_sky (buffer layout, float_count, metadata_json, job, cancel) for the view's
 * sun and observer. `view` and `options` may be NULL (the session's). */
AIRMASS_C_API int32_t airmass_sky_session_render(const airmass_sky_session* session, const airmass_sky_view* view,
                                                 const airmass_sky_options* options, float* rgba, size_t float_count,
                                                 const airmass_job* job, char** metadata_json, char* message,
                                                 size_t message_size);

AIRMASS_C_API void airmass_sky_session_free(airmass_sky_session* session); /* NULL is fine */

/* ---- Sunlight at the observer (for a Sun lamp) ------------------------------------------------ */

typedef struct airmass_sun_light {
    uint32_t struct_size;
    double direction[3];           /* unit vector toward the sun, scene frame (Z up)               */
    double irradiance_rgb[3];      /* transmitted direct sun, linear Rec.709, W m⁻² in the sky
                                      texture's units (Σ E·T·CMF·Δλ, no 683 lm/W) — what a Sun lamp
                                      of strength S and colour C gives as S·C                      */
    double irradiance_top_rgb[3];  /* the same at the top of the atmosphere (no extinction)        */
    double transmittance_rgb[3];   /* irradiance_rgb / irradiance_top_rgb (0 where the top is 0)   */
    double angular_diameter_deg;   /* of the sun disc                                              */
    int32_t below_horizon;         /* 1 when the planet blocks the sun at the observer             */
} airmass_sun_light;

AIRMASS_C_API int32_t airmass_sun_light_at_observer(const airmass_scene_spec* spec, const char* chapman,
                                                    airmass_sun_light* out, char* message, size_t message_size);

/* ---- Solar position (NREL SPA; docs/sun.md) ---------------------------------------------------
 *
 * The sun's topocentric position for a place on Earth and a moment in UTC, as `airmass sun`
 * prints it: NREL's Solar Position Algorithm (Reda & Andreas 2004/2008, ±0.0003°), no
 * atmospheric refraction (the sky model bends no rays, so the geometric sun is the one that
 * matches the rendered sky). Cheap (microseconds): no job, no progress. */

typedef struct airmass_solar_query {
    uint32_t struct_size;
    double latitude_deg;      /* geodetic, north positive, [-90, 90]                           */
    double longitude_deg;     /* east positive, [-180, 180]                                    */
    const char* utc;          /* ISO 8601 with a zone: "2026-06-21T04:00:00Z", "...+02:00"     */
    double site_elevation_m;  /* observer height above sea level (parallax only); 0 by default */
    double delta_t_s;         /* ΔT = TT − UT1, seconds; NaN (default): Espenak & Meeus         */
    double delta_ut1_s;       /* UT1 − UTC, seconds, |value| ≤ 1; 0 by default                 */
} airmass_solar_query;

/* latitude/longitude 0, utc NULL (must be set), site elevation 0, ΔT NaN, ΔUT1 0. */
AIRMASS_C_API int32_t airmass_solar_query_init(airmass_solar_query* query); /* struct_size set first */

typedef struct airmass_sun_position {
    uint32_t struct_size;
    double elevation_deg;          /* topocentric, above the astronomical horizon, [-90, 90]  */
    double azimuth_deg;            /* from north, clockwise (east = 90°), [0, 360)            */
    double zenith_deg;             /* 90 − elevation                                           */
    double blender_elevation_deg;  /* Sky Texture angles for a scene whose +Y is north and   */
    double blender_rotation_deg;   /*   +X east (= elevation and azimuth; docs/sun.md)        */
    double julian_day;             /* UT1                                                       */
    double delta_t_s;              /* the ΔT used                                               */
} airmass_sun_position;

/* Fills `out` (its struct_size set by the caller). Errors (AIRMASS_INVALID_ARGUMENT) name the
 * field, the value and the allowed range, e.g. "latitude_deg = 91: must be in [-90, 90]" or
 * "utc '2026-02-30T00:00Z': day 30 does not exist in that month". */
AIRMASS_C_API int32_t airmass_solar_position(const airmass_solar_query* query, airmass_sun_position* out,
                                             char* message, size_t message_size);

/* ---- Volumes (vdb_export's OpenVDB-free volume layer) ---------------------------------------------
 *
 * The atmosphere as sparse float grids, one per active constituent (docs/vdb.md). The library
 * makes every decision — region, voxel size, active voxels, tiling, metadata, file names — and
 * computes the values; the HOST builds the OpenVDB grids and writes the files with its own
 * OpenVDB (the Blender add-on: Blender's `openvdb` / `pyopenvdb` module), which gives exactly the
 * grids `airmass vdb` writes:
 *   1. airmass_vdb_plan      → the plan (JSON): every grid and file, without the voxels;
 *   2. airmass_vdb_grid_values, per grid (or per part of a grid) → its densities as a dense block;
 *      the host copies each block into its grid (`grid.copyFromArray(block, ijk=min,
 *      tolerance=0)`), sets the grid's transform, class and metadata from the plan, and writes
 *      each file of the plan.
 * Both calls take the same spec and options; the block call resolves them again (cheap) and
 * samples only its box. Lengths are in the chosen unit (km by default). */

typedef struct airmass_vdb_options {
    uint32_t struct_size;
    const char* region;       /* "planet" | "view" (needs the spec's camera) | "box"          */
    const char* unit;         /* "km" | "m"                                                    */
    int32_t origin_center;    /* 0: origin on the surface below the observer; 1: planet centre */
    double voxel_size;        /* in `unit`; NaN or 0: automatic (< 0 is an error)              */
    double box[6];            /* region "box": xmin, ymin, zmin, xmax, ymax, zmax in `unit`     */
    double tolerance;         /* NaN: default (1e-4)                                            */
    double max_dense_mb;      /* NaN: default (1024)                                            */
    int32_t tile_voxels;      /* 0 automatic tiling, -1 one tile, N > 0 tiles of N voxels       */
    const char* voxel_values; /* "auto" | "average" | "point" (NULL: auto): what a voxel holds,
                                 the density's mean over its trilinear footprint or the density at
                                 its centre; auto chooses per constituent (docs/vdb.md, Voxel values) */
} airmass_vdb_options;

/* Defaults: region "planet", unit "km", origin on the surface, automatic voxel size, default
 * tolerance and dense limit (NaN), automatic tiling, voxel values "auto". */
AIRMASS_C_API int32_t airmass_vdb_options_init(airmass_vdb_options* options); /* struct_size set first */

/* The plan of the volume, as JSON in `*plan_json` (free with airmass_string_free). Runs the
 * sampling pass (a long call: progress and cancel through `job`, which may be NULL) and refuses,
 * with the option's name and a suggestion, what `airmass vdb` refuses (dense boxes above
 * max_dense_mb, a region outside the atmosphere, ...). `file_stem` names the files (NULL:
 * "atmosphere"). The object (docs/vdb.md, "Host-written volumes"):
 *   "format": "airmass-vdb-plan", "format_version": 1, "unit", "region", "voxel_size",
 *   "voxel_size_automatic",
 *   "transform": {"voxel_size": [v, v, v], "translation": [tx, ty, tz],
 *                 "matrix": [[v,0,0,0],[0,v,0,0],[0,0,v,0],[tx,ty,tz,1]], "convention"}:
 *       OpenVDB's linear transform, world = translation + v·(i, j, k) (translation is 0 today);
 *       the value of voxel (i, j, k) is the density at that world point, which OpenVDB takes as
 *       the centre of the voxel's cell [i − ½, i + ½]·v (Blender < 5.0 renders it half a voxel
 *       off: shift the Volume object by −v/2);
 *   "grid_class": "fog volume", "value_type": "float", "background": 0,
 *   "request_bounds": {"min": [3 ints], "max": [3 ints]}: the boxes airmass_vdb_grid_values takes,
 *   "tile_count", "tiling": {"tile_voxels", "base"},
 *   "grids": [{"index", "name", "tile", "bbox_min", "bbox_max" (inclusive index bounding box of
 *       the active voxels), "dim", "active_voxels" (exact), "dense_voxels", "dense_bytes",
 *       "memory_bytes_estimate", "metadata": {key: value}, "metadata_types": {key: "string" |
 *       "double" | "int32" | "vec3d"}}, ...] — tile-major, the grid name is the constituent;
 *   "files": [{"name", "tile", "grids": [indices into "grids"], "metadata", "metadata_types"}]:
 *       one .vdb per tile with the file-level metadata;
 *   "manifest": null, or {"name", "text"} for a tiled volume (the tiles manifest to write beside);
 *   "active_voxels", "dense_bytes", "dense_bytes_untiled", "memory_bytes_estimate",
 *   "build_seconds", "summary" (the report `airmass vdb` prints). */
AIRMASS_C_API int32_t airmass_vdb_plan(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                       const char* file_stem, const airmass_job* job, char** plan_json,
                                       char* message, size_t message_size);

/* Which values airmass_vdb_grid_values returns: one grid (= constituent) over an index box. */
typedef struct airmass_vdb_block {
    uint32_t struct_size;
    const char* grid;  /* the grid's name: a plan "grids"[].name                                */
    int32_t min[3];    /* inclusive index box, within the plan's "request_bounds"; a grid's     */
    int32_t max[3];    /*   "bbox_min"/"bbox_max" give the whole grid, or split it (along i)    */
    int32_t threads;   /* workers; 0: all hardware threads                                      */
} airmass_vdb_block;

/* grid NULL, an empty box (min 0, max −1), threads 0. */
AIRMASS_C_API int32_t airmass_vdb_block_init(airmass_vdb_block* block); /* struct_size set first */

/* The densities of block->grid at every voxel of the box, into the caller's `values`
 * (`float_count` must be exactly nx·ny·nz, n = max − min + 1 per axis): values[(i·ny + j)·nz + k]
 * is voxel min + (i, j, k) — C order with k (z) fastest, i.e. a numpy float32 array a[i][j][k] of
 * shape (nx, ny, nz), which is what OpenVDB's Python `grid.copyFromArray(a, ijk=min)` reads.
 * Inactive voxels are 0 (the grids' background), active ones are > 0, so copyFromArray with
 * tolerance 0 activates exactly the voxels `airmass vdb` activates. Over a plan grid's box the
 * values are that tile's grid: blocks of one grid may be requested in any number of parts (the
 * plan's boxes split at multiples of 8 in i keep OpenVDB's leaves whole). A long call: progress
 * and cancel through `job` (may be NULL). Errors name the field and the allowed range: an
 * unknown grid, an empty box, a box outside "request_bounds", a wrong float_count. On failure
 * the buffer's contents are unspecified. */
AIRMASS_C_API int32_t airmass_vdb_grid_values(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                              const airmass_vdb_block* block, float* values, size_t float_count,
                                              const airmass_job* job, char* message, size_t message_size);

/* ---- VDB sessions (ABI 8): one layout, its plan and all its grids' values -------------------
 * airmass_vdb_plan and airmass_vdb_grid_values resolve the layout and sample afresh at every call.
 * A session resolves it once and keeps the sampler, whose store holds each voxel mean that needs
 * quadrature once for all the voxels the planet's symmetry makes equal (docs/vdb.md, Voxel values,
 * Cost), and which keeps the plan's pass's blocks (up to 256 MiB of values; past that a block is
 * sampled again): the blocks asked after the plan are copies of what its pass computed — for
 * Earth's whole planet 0.2 s for every grid's values where the stateless calls take half a
 * minute. The values are those of the stateless calls with the same spec and options.
 *   1. airmass_vdb_session_create(spec, options, &session, ...): the scene and the layout (cheap);
 *   2. airmass_vdb_session_plan(session, file_stem, job, &plan_json, ...): as airmass_vdb_plan;
 *   3. airmass_vdb_session_grid_values(session, block, values, ...), per grid or part of one: as
 *      airmass_vdb_grid_values;
 *   4. airmass_vdb_session_free(session).
 * Calls on one session may run at once on several threads. */
typedef struct airmass_vdb_session airmass_vdb_session;

/* `*out` receives the session (NULL on failure); the errors are airmass_vdb_plan's option and
 * scene refusals. */
AIRMASS_C_API int32_t airmass_vdb_session_create(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                                 airmass_vdb_session** out, char* message, size_t message_size);
AIRMASS_C_API int32_t airmass_vdb_session_plan(const airmass_vdb_session* session, const char* file_stem,
                                               const airmass_job* job, char** plan_json, char* message,
                                               size_t message_size);
AIRMASS_C_API int32_t airmass_vdb_session_grid_values(const airmass_vdb_session* session,
                                                      const airmass_vdb_block* block, float* values,
                                                      size_t float_count, const airmass_job* job, char* message,
                                                      size_t message_size);
AIRMASS_C_API void airmass_vdb_session_free(airmass_vdb_session* session); /* NULL is fine */

/* The analytic density description (docs/vdb.md, "Analytic density") as JSON. */
AIRMASS_C_API int32_t airmass_analytic_density_json(const airmass_scene_spec* spec,
                                                    const airmass_vdb_options* options, char** json,
                                                    char* message, size_t message_size);

/* The sun's columns for a host that lights the atmosphere itself (the add-on's Analytic Sun
 * lighting; volume.hpp sun_column_table, docs/addon.md): per active constituent, in
 * airmass_analytic_density_json's order, the mass ∫ρ ds in options->unit along the ray from a
 * point toward the sun to the top of the atmosphere, on Bruneton's transmittance-texture
 * parametrisation (texel (i, j): x_mu = i/(mu_size−1), x_r = j/(r_size−1)). mu_size and r_size
 * in [2, 4096]; `values` holds exactly r_size × mu_size × (constituent count) floats, laid out
 * [(j · mu_size + i) · count + k]. Sizes and buffer are checked before any work. ≈ 7 ms at 256 × 64
 * (earth): no job. */
AIRMASS_C_API int32_t airmass_sun_column_table(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                               int32_t mu_size, int32_t r_size, float* values, size_t float_count,
                                               char* message, size_t message_size);

/* The multiple scattering of the same lighting (volume.hpp sun_ms_table): Hillaire's isotropic
 * Ψ(altitude, sun zenith) per unit top-of-atmosphere irradiance, sr⁻¹, at the exporter's three RGB
 * wavelengths; texel (i, j): μs = *mu_s_min + (1 − *mu_s_min)·i/(mu_size−1), x_r = j/(r_size−1).
 * `values` holds exactly r_size × mu_size × 3 floats, [(j · mu_size + i) · 3 + c]; *mu_s_min is
 * written on success. Sizes and buffer are checked before any work. ≈ 0.2 s at 64 × 32 (earth, 2 threads:
 * the library's Ψ precompute at three wavelengths): no job. */
AIRMASS_C_API int32_t airmass_sun_ms_table(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                           int32_t mu_size, int32_t r_size, float* values, size_t float_count,
                                           double* mu_s_min, char* message, size_t message_size);

#ifdef __cplusplus
}
#endif

#endif /* AIRMASS_C_H */
