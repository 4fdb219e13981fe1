// airmass: the command-line front end of libairmass.
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>

#include "airmass/version.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
    // `airmass --version`: answered before any command is set up (nothing else is touched).
    if (argc == 2 && (std::strcmp(argv[1], "--version") == 0 || std::strcmp(argv[1], "-V") == 0)) {
        std::printf("airmass %s\n", airmass::version_string());
        return 0;
    }
    // A file-size limit (ulimit -f) reached by a writer: the write fails with EFBIG and the
    // writer reports it and removes its temporary (airmass/atomic_file.hpp), instead of
    // SIGXFSZ ending the process with the temporary left behind.
    std::signal(SIGXFSZ, SIG_IGN);
    CLI::App app{"airmass: a planet's atmosphere around a fast, well-tested Chapman function"};
    // Listed in --help; the fast path above answers it alone.
    app.set_version_flag("-V,--version", std::string("airmass ") + airmass::version_string());
    app.require_subcommand(1);
    airmass::cli::add_chapman_command(app);
    airmass::cli::add_eval_command(app);
    airmass::cli::add_sky_command(app);
    airmass::cli::add_vdb_command(app);
    airmass::cli::add_render_command(app);
    airmass::cli::add_compare_command(app);
    airmass::cli::add_sun_command(app);
    airmass::cli::add_pov_command(app);
    auto* report = app.add_subcommand("report", "Measured speed-vs-accuracy trade tables and plots' data");
    report->require_subcommand(1);
    airmass::cli::add_report_chapman(*report);
    airmass::cli::add_report_sky(*report);
    airmass::cli::add_report_vdb(*report);
    airmass::cli::add_report_ms(*report);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version: 0. A bad command line (an unknown option, a value out of its
        // range or not a number: CLI11's own codes 100-127) exits 2 like every other refusal.
        return app.exit(e) == 0 ? 0 : 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "airmass: %s\n", e.what());
        return 2;
    }
    return 0;
}
