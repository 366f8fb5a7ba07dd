// The user-facing fields of trilevel::Params as the two front ends offer them: the CLI's
// `trilevel reconstruct` options and the Python keywords of trilevel.reconstruct. One table holds,
// per field, the option, the keyword, the one-line help and how to read the value, so that both
// take their defaults from Params{} and their help from the same line (tests compare both against it).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// A parameter's value as the front ends show it: unset (Python None, CLI option not given), a
/// switch, a whole number, a byte count, a real number or a word ("adaptive").
using ParamValue = std::variant<std::monostate, bool, int, std::uint64_t, float, std::string>;

/// One field of Params.
struct ParamInfo {
    std::string field;   ///< the Params member
    std::string cli;     ///< CLI11 names of the `trilevel reconstruct` option, e.g. "-r,--radius"
    std::string python;  ///< keyword of trilevel.reconstruct (and Reconstructor.reconstruct)
    std::string help;    ///< one line, without the default: the CLI and the docstrings append theirs
    ParamValue (*read)(const Params&) = nullptr;  ///< the field's value as the front ends write it
    /// What the default value stands for where it is a placeholder that the CLI does not accept
    /// (curvature threshold 0: the calibrated one); empty otherwise.
    std::string default_means;
    /// The CLI's default where it differs from Params{}, as option text parsed like a user's; empty:
    /// Params{}'s. Only the level hysteresis (0.2: the CLI meshes sequences, the library each call alone).
    std::string cli_default;
    bool required = false;  ///< no default: the CLI requires the option, Python the argument
};

/// Every user-facing field of Params, in the order of the Python keywords.
const std::vector<ParamInfo>& param_table();

/// The entry of Params field `field`; throws Error for an unknown one.
const ParamInfo& param_info(std::string_view field);

/// `v` as text: "4", "0.32" (the shortest text that reads back as the same float), "adaptive",
/// "on"/"off"; "" when unset.
std::string param_value_text(const ParamValue& v);

/// The default of `info` as the CLI's --help shows it: `default_means` if set, else the CLI's own
/// default, else Params{}'s value; "" where there is none to show (required, unset, switches).
std::string param_cli_default_text(const ParamInfo& info);

}  // namespace trilevel
