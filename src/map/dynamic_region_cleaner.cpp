#include "dynamap/map/dynamic_region_cleaner.hpp"

#include "dynamap/map/map_params.hpp"

namespace dynamap {

Status DynamicRegionCleanerConfig::validate() const noexcept {
  return all_in_range(*this, params::kDynamicRegionCleaner) &&
                 all_hold(*this, params::kDynamicRegionCleanerRelations)
             ? Status::kOk
             : Status::kInvalidArgument;
}

}  // namespace dynamap
