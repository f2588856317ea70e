// SPDX-License-Identifier: Apache-2.0
// rockvdb — error types shared by every op, tool and binding.
//
// ValueError    a parameter or input value is wrong      CLI exit 2, Python ValueError
// IoError       a file is missing, unreadable or invalid  CLI exit 1, Python IOError
// Interrupted   the user or a host application cancelled  CLI exit 1, Python KeyboardInterrupt
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace rockvdb {

class ValueError : public std::invalid_argument
{
public:
    using std::invalid_argument::invalid_argument;
};

class IoError : public std::runtime_error
{
public:
    using std::runtime_error::runtime_error;
};

class Interrupted : public std::runtime_error
{
public:
    Interrupted() : std::runtime_error("interrupted") {}
};

/// @brief Build a message from stream-able parts: `fail<ValueError>("bake: voxel size ", v)`.
template<typename ErrorT, typename... Args>
[[noreturn]] void fail(Args&&... args)
{
    std::ostringstream os;
    (os << ... << args);
    throw ErrorT(os.str());
}

/// @brief Throw ValueError("<op>: <what> must be <rule> (got <value>)") unless @a ok.
template<typename T>
void require(bool ok, const char* op, const char* what, const char* rule, const T& value)
{
    if (!ok) fail<ValueError>(op, ": ", what, " must be ", rule, " (got ", value, ")");
}

} // namespace rockvdb
