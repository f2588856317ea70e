// SPDX-License-Identifier: Apache-2.0
// pyopenvdb.FloatGrid <-> openvdb::FloatGrid::Ptr for pybind11 functions.
// pyopenvdb 10 is a boost.python module: convert through boost::python's registry (which
// `import pyopenvdb` populates). None is rejected, so pybind11 raises TypeError.
#pragma once

#include <boost/python.hpp>
#include <openvdb/openvdb.h>
#include <pybind11/pybind11.h>

namespace pybind11 {
namespace detail {

template<>
struct type_caster<openvdb::FloatGrid::Ptr>
{
    PYBIND11_TYPE_CASTER(openvdb::FloatGrid::Ptr, _("pyopenvdb.FloatGrid"));

    bool load(handle src, bool)
    {
        if (!src || src.is_none()) return false;
        namespace bp = boost::python;
        bp::object obj(bp::handle<>(bp::borrowed(src.ptr())));
        bp::extract<openvdb::FloatGrid::Ptr> ex(obj);
        if (!ex.check()) return false;
        value = ex();
        return bool(value);
    }

    static handle cast(const openvdb::FloatGrid::Ptr& grid, return_value_policy, handle)
    {
        if (!grid) return none().release();
        boost::python::object obj(grid);
        return boost::python::incref(obj.ptr());
    }
};

} // namespace detail
} // namespace pybind11
