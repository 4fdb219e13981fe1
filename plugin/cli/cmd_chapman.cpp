// `airmass chapman`: point evaluation of the Chapman function family from stdin.
//   in:  x,chi_deg            (header line allowed, '#' comments skipped)
//   out: x,chi_deg,ch,ln_ch   (17 significant digits; ch reads inf beyond double)
#include <cstdio>
#include <iostream>
#include <string>

#include "airmass/chapman.hpp"
#include "commands.hpp"
#include "csv.hpp"

namespace airmass::cli {

namespace {

template <class T>
void evaluate_rows(ChapmanMethod method, const std::vector<NumericRow>& rows) {
    std::string out = "x,chi_deg,ch,ln_ch\n";
    for (const auto& row : rows) {
        const T x = static_cast<T>(row.values[0]);
        const auto chi = ZenithAngle<T>::from_degrees(row.values[1]);
        const auto s = chapman_scaled(method, x, chi);
        const double ln_ch = std::log(static_cast<double>(s.mantissa)) + static_cast<double>(s.log_scale);
        const double ch = static_cast<double>(chapman(method, x, chi));
        out += format_g17(row.values[0]) + "," + format_g17(row.values[1]) + "," + format_g17(ch) + "," +
               format_g17(ln_ch) + "\n";
    }
    write_stdout(out, "chapman");
}

}  // namespace

void add_chapman_command(CLI::App& app) {
    auto* cmd = app.add_subcommand("chapman", "Evaluate Ch(x, chi) for x,chi_deg rows read from stdin");
    auto method_name = std::make_shared<std::string>("airmass");
    auto precision = std::make_shared<std::string>("double");
    auto list = std::make_shared<bool>(false);
    cmd->add_option("--method", *method_name, "Chapman method (see --list-methods)");
    cmd->add_option("--precision", *precision, "Arithmetic: float or double")->check(CLI::IsMember({"float", "double"}));
    cmd->add_flag("--list-methods", *list, "Print one method per line: name, then a description");
    cmd->callback([=] {
        if (*list) {
            for (const auto& m : chapman_methods())
                std::printf("%.*s  %.*s\n", int(m.name.size()), m.name.data(), int(m.description.size()),
                            m.description.data());
            return;
        }
        const auto method = chapman_method_from_name(*method_name);
        if (!method) throw CliError("chapman: unknown --method '" + *method_name + "' (see --list-methods)");
        const auto rows = read_chapman_rows(std::cin, *precision == "float");
        if (*precision == "float") evaluate_rows<float>(*method, rows);
        else evaluate_rows<double>(*method, rows);
    });
}

}  // namespace airmass::cli
