// The database schema each COLMAP release creates: its CREATE statements and
// the user_version it sets (src/base/database.cc in 3.8,
// src/colmap/scene/database.cc from 3.9, database_sqlite.cc from 3.13). For
// writing databases as another release would, chiefly in tests; hisfm
// itself copies a database's own schema (WriteFilteredDatabase).
#pragma once

#include <string>
#include <vector>

#include "hisfm/io/colmap_version.h"

namespace hisfm {

/// The CREATE TABLE and CREATE INDEX statements of `release`, in COLMAP's
/// order: 3.8 and 3.9 alike; 3.10 moves the image priors into pose_priors;
/// 3.11 adds pose_priors.position_covariance; 3.12 adds rigs, rig_sensors,
/// frames and frame_data (3.13 alike); 4.0 keys pose_priors by
/// pose_prior_id and adds descriptors.type (4.1 alike).
std::vector<std::string> ColmapSchemaStatements(ColmapRelease release);

/// The PRAGMA user_version `release` writes into its databases: 3800 for 3.8
/// (COLMAP_VERSION_NUMBER), 3900 for 3.9 to 3.12, and from 3.13 on
/// major * 1000000 + minor * 10000 (MakeDatabaseVersionNumber, patch 0).
int ColmapSchemaUserVersion(ColmapRelease release);

}  // namespace hisfm
