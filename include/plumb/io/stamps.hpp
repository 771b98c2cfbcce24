// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Putting a recording's records in time order when their stamps are not usable as they
/// are: a clock stepped back (some records go back in time) or a clock quantised (runs of records
/// share one stamp, e.g. a logger writing whole seconds, or 10 s).

#include <cstddef>
#include <vector>

namespace plumb::io {

/// @brief Which records to keep and the stamps to give them (see order_stamps()).
struct StampOrder {
  std::vector<std::size_t> kept;    ///< indices of the records kept, in message order
  std::vector<double> stamps;       ///< one per kept record, strictly increasing
  std::vector<std::size_t> dropped;  ///< records whose stamp went back in time
  std::size_t respread = 0;          ///< kept records whose stamp was shared and has been spread
};

/// @brief Message order with stamps that strictly increase.
///
/// A record whose stamp is below the last kept one is dropped (a clock stepped back; the records
/// after it carry on). A run of records sharing one stamp (a quantised clock) is kept in message
/// order, its stamps spread evenly from the shared stamp up to the next larger one; the last such
/// run, with nothing after it, takes the spacing of the runs before it (or 1 ms).
/// @param stamps finite stamps [s], in message order.
StampOrder order_stamps(const std::vector<double>& stamps);

}  // namespace plumb::io
