// SPDX-License-Identifier: Apache-2.0
// TSan builds only (ROCKVDB_SANITIZE=thread puts .ci/tsan-include first on the include path).
// Debian's libopenvdb is built without TSan and with explicit template instantiation, so the
// parallel tree operations it instantiates (signedFloodFill, NodeManager, LeafManager...) run
// TBB task joins TSan cannot see, and every read their workers made looks like it races with
// whatever the caller does next. Without OPENVDB_USE_EXPLICIT_INSTANTIATION the headers'
// `extern template` declarations go away: those templates are instantiated in our own,
// instrumented translation units, and TSan sees every join (with libtbb built with TSan too).
#include_next <openvdb/version.h>
#undef OPENVDB_USE_EXPLICIT_INSTANTIATION
