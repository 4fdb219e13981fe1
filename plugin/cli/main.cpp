// airmass: the command-line front end of libairmass.
#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "airmass/spelling.hpp"
#include "airmass/version.hpp"
#include "airmass/compare_plan.hpp"
#include "commands.hpp"

namespace {

// Where the command line got to: the subcommands it reached ("sky", "report sky"; empty before
// any), the deepest of them (or the app) and the argv index after their words.
struct Reached {
    std::string path;
    const CLI::App* level;
    int next;
};

Reached reached(const CLI::App& app, int argc, char** argv) {
    Reached r{"", &app, 1};
    while (!r.level->get_subcommands().empty()) {
        r.level = r.level->get_subcommands().front();
        r.path += (r.path.empty() ? "" : " ") + r.level->get_name();
        while (r.next < argc && r.level->get_name() != argv[r.next]) ++r.next;
        ++r.next;
    }
    return r;
}

// The first word after the command's words that looks like an option (`--name`,
// `--name=v`, `-x`; not a value such as `-5` or `-inf`, not after `--`) but is none of the
// command's. With its value it otherwise becomes a positional, and CLI11 reports something
// else ("scene excludes --preset" for `airmass sky --preset earth --out x.exr`). Names the
// option that begins with the word or, failing that, the nearest of which it looks like a
// misspelling (airmass/spelling.hpp).
std::string unknown_option(const Reached& r, char** argv, int argc) {
    for (int i = r.next; i < argc; ++i) {
        const std::string word = argv[i];
        if (word == "--") break;
        const bool long_form = word.size() > 2 && word[0] == '-' && word[1] == '-';
        const bool short_form = word.size() == 2 && word[0] == '-';  // `-5`, `-inf`: values
        if (!(long_form || short_form) || !std::isalpha(static_cast<unsigned char>(word[long_form ? 2 : 1])))
            continue;
        const std::string name = word.substr(0, word.find('='));
        if (r.level->get_option_no_throw(name) != nullptr) continue;
        const std::string_view typed = std::string_view(name).substr(name[1] == '-' ? 2 : 1);
        std::string nearest;
        std::size_t best = std::string::npos;
        if (long_form)
            for (const CLI::Option* opt : r.level->get_options())
                for (const std::string& long_name : opt->get_lnames()) {
                    std::size_t d = std::string::npos;
                    if (long_name.rfind(typed, 0) == 0) d = 0;  // the start of it
                    else if (airmass::looks_like_misspelling(typed, long_name)) d = airmass::edit_distance(typed, long_name);
                    if (d < best) best = d, nearest = "--" + long_name;
                }
        return "unknown option '" + name + "'" + (nearest.empty() ? "" : " (did you mean " + nearest + "?)");
    }
    return {};
}

// CLI11's message, starting lower-case after "airmass: <command>: ", except where it misleads:
// a word that is not a command, where one is expected, reads "A subcommand is required"; say
// which word and list the commands of that level. An unknown option is named first, whatever
// CLI11 made of it.
std::string parse_message(const Reached& r, const CLI::ParseError& e, char** argv, int argc) {
    const auto commands = r.level->get_subcommands([](const CLI::App*) { return true; });
    if (!commands.empty() && r.next < argc && argv[r.next][0] != '-') {
        std::string names;
        for (const CLI::App* sub : commands) names += (names.empty() ? "" : ", ") + sub->get_name();
        return std::string("unknown command '") + argv[r.next] + "' (commands: " + names + ")";
    }
    if (std::string unknown = unknown_option(r, argv, argc); !unknown.empty()) return unknown;
    std::string what = e.what();
    if (what.size() > 1 && std::isupper(static_cast<unsigned char>(what[0])) &&
        std::islower(static_cast<unsigned char>(what[1])))
        what[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(what[0])));
    return what;
}

}  // namespace

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
    // The comparison's plan (compare/plan.json, built in) is read while the commands are set
    // up; a malformed one is a build defect, said here with the field it names (exit 70),
    // not an uncaught exception in every command.
    try {
        (void)airmass::compare::path_table();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "airmass: internal error: %s\n", e.what());
        return 70;
    }
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
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // A bad command line (an unknown option or command, a value out of its range or not a
        // number) is refused like every other error: one line `airmass: <command>: <what>`,
        // then where the options are listed; exit 2.
        const Reached r = reached(app, argc, argv);
        const std::string where = r.path.empty() ? std::string("airmass") : "airmass " + r.path;
        std::fprintf(stderr, "airmass: %s%s\n(`%s --help` lists the %s)\n",
                     r.path.empty() ? "" : (r.path + ": ").c_str(), parse_message(r, e, argv, argc).c_str(),
                     where.c_str(), r.path.empty() ? "commands" : "options");
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "airmass: %s\n", e.what());
        return 2;
    }
    return 0;
}
