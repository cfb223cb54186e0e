#pragma once
// Changes of a world between sessions, read from a YAML change set (doc/simulation.md):
//
//   changes:
//     - {session: 1, kind: box, action: add, center: [3.0, 4.5], size: [0.8, 0.6], yaw: 0.3}
//     - {session: 2, kind: box, action: remove, center: [3.0, 4.5], size: [0.8, 0.6]}
//     - {session: 2, kind: door, action: close, from: [7.0, 1.0], to: [7.0, 2.0]}
//
// A change listed for session k holds in the world of session k and of every later session;
// changes apply in session order, and in file order within a session. A box is a rectangle
// (centre, size along its own axes, yaw) whose cells become occupied (add) or free (remove); a
// door is a segment whose cells become occupied (close) or what lies beneath the doors there
// (open): the world file's drawing with the box changes so far, so a door drawn from wall to wall
// leaves the walls whole, a doorway cut by a box stays cut and a box under the door stays. An
// open door that no change closed would change nothing and is refused (validateOpenings): to cut
// an opening, remove a box.

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/sim/world.h"

namespace rrr_graphslam::sim {

struct WorldChange {
  enum class Kind { kBox, kDoor };
  int session = 0;  ///< first session whose world has the change (sessions count from 0)
  Kind kind = Kind::kBox;
  bool adds = true;  ///< box add / door close (cells become occupied); else removed / opened
  Eigen::Vector2d center_m = Eigen::Vector2d::Zero();  ///< box centre, world frame
  Eigen::Vector2d size_m = Eigen::Vector2d::Zero();    ///< box extent along its own x and y
  double yaw_rad = 0.0;                                ///< box orientation (default 0)
  Eigen::Vector2d from_m = Eigen::Vector2d::Zero();    ///< door segment ends, world frame
  Eigen::Vector2d to_m = Eigen::Vector2d::Zero();
  double thickness_m = 0.1;  ///< door leaf (default 0.1; at least 1.5 cells are covered)
  std::string label;         ///< "change K" (1-based, in file order), for messages
  std::string path;          ///< the file it was read from, for messages
  std::size_t line = 0;      ///< 1-based line of the entry in its file
};

struct ChangeSet {
  std::string path;
  std::vector<WorldChange> changes;  ///< file order
};

/// Throws core::InputError naming the file, the line and the entry ("change 3: 'kind' must be box
/// or door, not 'boxx'") for a missing, unknown or malformed field.
ChangeSet readChanges(const std::string& path);

/// Throws core::InputError naming the entry for a change that covers no cell of `world` (e.g.
/// coordinates in another frame or unit).
void validateChanges(const ChangeSet& changes, const World& world);

/// Throws core::InputError naming the entry (its file and line) for a door opened where no
/// earlier change closed one: it would change no cell. `changes` may join the sets of several
/// files in the order they apply (a door closed in one and opened in another is fine).
void validateOpenings(const ChangeSet& changes, const World& base);

/// Applies one change to `world`; `beneath` is the world beneath the doors (the world file's
/// drawing with the box changes so far, as worldOfSession keeps it), whose cells an opened door
/// takes back. Returns the number of cells the change covers. std::invalid_argument if the two
/// grids differ.
std::size_t applyChange(World& world, const WorldChange& change, const World& beneath);

/// The world of `session`: `base` with every change of sessions 0..session applied.
World worldOfSession(const World& base, const ChangeSet& changes, int session);

}  // namespace rrr_graphslam::sim
