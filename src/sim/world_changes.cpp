#include "rrr_graphslam/sim/world_changes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/sim/yaml_fields.h"

namespace rrr_graphslam::sim {
namespace {

constexpr double kMaxCoordinate = 1e6;  // m; anything beyond is a unit mistake

Eigen::Vector2d point(const YamlEntry& e, const std::string& key) {
  const std::vector<double> v = e.numbers(key, 2);
  if (std::abs(v[0]) > kMaxCoordinate || std::abs(v[1]) > kMaxCoordinate) {
    e.fail(key, "lies beyond 1e6 m");
  }
  return {v[0], v[1]};
}

WorldChange readChange(const YamlEntry& e) {
  WorldChange c;
  c.line = e.line();
  c.session = static_cast<int>(e.integer("session", 0, 1000000));
  const std::string kind = e.string("kind");
  const std::string action = e.string("action");
  if (kind == "box") {
    c.kind = WorldChange::Kind::kBox;
    if (action != "add" && action != "remove") {
      e.fail("action", "of a box must be add or remove, not '" + action + "'");
    }
    c.adds = action == "add";
    c.center_m = point(e, "center");
    c.size_m = point(e, "size");
    if (c.size_m.minCoeff() <= 0.0) e.fail("size", "must be positive in both directions");
    c.yaw_rad = e.numberOr("yaw", 0.0, -2.0 * M_PI, 2.0 * M_PI);
    e.expectOnly({"session", "kind", "action", "center", "size", "yaw"});
  } else if (kind == "door") {
    c.kind = WorldChange::Kind::kDoor;
    if (action != "close" && action != "open") {
      e.fail("action", "of a door must be close or open, not '" + action + "'");
    }
    c.adds = action == "close";
    c.from_m = point(e, "from");
    c.to_m = point(e, "to");
    if ((c.to_m - c.from_m).norm() <= 0.0) e.fail("to", "must differ from 'from'");
    c.thickness_m = e.numberOr("thickness", 0.1, 1e-3, 10.0);
    e.expectOnly({"session", "kind", "action", "from", "to", "thickness"});
  } else {
    e.fail("kind", "must be box or door, not '" + kind + "'");
  }
  return c;
}

// Whether a world point lies in the change's footprint.
bool covers(const WorldChange& c, const Eigen::Vector2d& p, double resolution_m) {
  if (c.kind == WorldChange::Kind::kBox) {
    const double cs = std::cos(c.yaw_rad), sn = std::sin(c.yaw_rad);
    const Eigen::Vector2d d = p - c.center_m;
    const Eigen::Vector2d local(cs * d.x() + sn * d.y(), -sn * d.x() + cs * d.y());
    return std::abs(local.x()) <= 0.5 * c.size_m.x() && std::abs(local.y()) <= 0.5 * c.size_m.y();
  }
  // A door spans from its one post to the other (no further: opening it leaves the walls), and
  // is at least 1.5 cells thick, so that no beam slips between its cells on a diagonal.
  const Eigen::Vector2d ab = c.to_m - c.from_m;
  const double t = (p - c.from_m).dot(ab) / ab.squaredNorm();
  if (t < 0.0 || t > 1.0) return false;
  const double distance = (p - (c.from_m + t * ab)).norm();
  return distance <= std::max(0.5 * c.thickness_m, 0.75 * resolution_m);
}

// The cells whose centres the change covers.
template <class F>
std::size_t forEachCoveredCell(const World& world, const WorldChange& c, F&& f) {
  Eigen::Vector2d lo, hi;
  if (c.kind == WorldChange::Kind::kBox) {
    const double r = 0.5 * c.size_m.norm();
    lo = c.center_m.array() - r;
    hi = c.center_m.array() + r;
  } else {
    const double r = std::max(0.5 * c.thickness_m, 0.75 * world.resolution_m);
    lo = c.from_m.cwiseMin(c.to_m).array() - r;
    hi = c.from_m.cwiseMax(c.to_m).array() + r;
  }
  const Eigen::Vector2i a = world.cellOf(lo).cwiseMax(Eigen::Vector2i::Zero());
  const Eigen::Vector2i b =
      world.cellOf(hi).cwiseMin(Eigen::Vector2i(world.width - 1, world.height - 1));
  std::size_t n = 0;
  for (int cy = a.y(); cy <= b.y(); ++cy) {
    for (int cx = a.x(); cx <= b.x(); ++cx) {
      if (covers(c, world.centerOf(cx, cy), world.resolution_m)) {
        f(cx, cy);
        ++n;
      }
    }
  }
  return n;
}

// A box's cells, or a closed door's, set to what the change makes them.
std::size_t paint(World& world, const WorldChange& c) {
  const Cell value = c.adds ? Cell::kOccupied : Cell::kFree;
  return forEachCoveredCell(world, c, [&](int cx, int cy) { world.set(cx, cy, value); });
}

}  // namespace

ChangeSet readChanges(const std::string& path) {
  ChangeSet set;
  set.path = path;
  const YamlDocument doc(path);
  const YamlEntry root = doc.root("a change set ('changes:' and a list of entries)");
  root.expectOnly({"changes"});
  for (const YamlEntry& e : root.entries("changes", "change")) {
    WorldChange c = readChange(e);
    c.label = "change " + std::to_string(set.changes.size() + 1);
    c.path = path;
    set.changes.push_back(c);
  }
  return set;
}

void validateChanges(const ChangeSet& changes, const World& world) {
  for (const WorldChange& c : changes.changes) {
    if (forEachCoveredCell(world, c, [](int, int) {}) == 0) {
      const Eigen::Vector2d hi =
          world.origin_m + world.resolution_m * Eigen::Vector2d(world.width, world.height);
      std::ostringstream what;
      what << c.label << ": covers no cell of the world, which spans x [" << world.origin_m.x()
           << ", " << hi.x() << "], y [" << world.origin_m.y() << ", " << hi.y() << "] m";
      throw core::InputError(changes.path, c.line, what.str());
    }
  }
}

std::size_t applyChange(World& world, const WorldChange& change, const World& beneath) {
  if (beneath.width != world.width || beneath.height != world.height ||
      beneath.resolution_m != world.resolution_m || beneath.origin_m != world.origin_m) {
    throw std::invalid_argument("applyChange: the world beneath the doors has another grid");
  }
  if (change.kind == WorldChange::Kind::kDoor && !change.adds) {
    // An open door gives back what lies beneath it: the posts of a door drawn from wall to wall
    // stand in the walls, which opening it must not breach, and an opening cut by a box stays cut.
    return forEachCoveredCell(world, change,
                              [&](int cx, int cy) { world.set(cx, cy, beneath.at(cx, cy)); });
  }
  return paint(world, change);
}

namespace {

// Applies the changes of sessions 0..session to `base` in their order, calling
// before(change, world, beneath) ahead of each; returns the world. Two layers: every change, and
// beneath the doors, the boxes alone (what an opened door gives back).
template <class Before>
World replayChanges(const World& base, const ChangeSet& changes, int session, Before before) {
  std::vector<const WorldChange*> due;
  for (const WorldChange& c : changes.changes) {
    if (c.session <= session) due.push_back(&c);
  }
  std::stable_sort(due.begin(), due.end(), [](const WorldChange* a, const WorldChange* b) {
    return a->session < b->session;
  });
  World world = base;
  World beneath = base;
  for (const WorldChange* c : due) {
    before(*c, world, beneath);
    applyChange(world, *c, beneath);
    if (c->kind == WorldChange::Kind::kBox) paint(beneath, *c);
  }
  return world;
}

}  // namespace

void validateOpenings(const ChangeSet& changes, const World& base) {
  const auto check = [&](const WorldChange& c, const World& world, const World& beneath) {
    if (c.kind != WorldChange::Kind::kDoor || c.adds) return;
    std::size_t closed = 0;
    forEachCoveredCell(world, c,
                       [&](int cx, int cy) { closed += world.at(cx, cy) != beneath.at(cx, cy); });
    if (closed > 0) return;
    throw core::InputError(c.path.empty() ? changes.path : c.path, c.line,
                           c.label +
                               ": opens a door no earlier change closed: its cells would not "
                               "change (to cut an opening into a wall, remove a box there)");
  };
  replayChanges(base, changes, std::numeric_limits<int>::max(), check);
}

World worldOfSession(const World& base, const ChangeSet& changes, int session) {
  return replayChanges(base, changes, session,
                       [](const WorldChange&, const World&, const World&) {});
}

}  // namespace rrr_graphslam::sim
