#pragma once

#include <cstddef>
#include <string>

namespace cube {

/// How `update()` and friends keep the hierarchy in shape after objects move.
enum class UpdatePolicy {
  /// Refit the cubes in place; rebuild from scratch when the tree quality degrades past
  /// `Config::rebuild_threshold` (after updates, also past `Config::rebuild_budget`) or when
  /// many objects were added or removed since the last build.
  automatic,
  /// Only refit: cheapest per update, but queries slow down as objects wander from where the
  /// hierarchy was built. The hierarchy is still rebuilt by `setup()` after registrations.
  refit,
  /// Rebuild from scratch on every update: right for scenes that are reshuffled each step.
  rebuild,
};

/// Every knob of the cube hierarchy. A default-constructed Config is what most users want.
struct Config {
  /// The deepest level of cubes. 0 (automatic): split until every leaf holds at most `leaf_size`
  /// objects. k > 0: at most k levels below the root; cubes at level k keep all their objects,
  /// which are then tested pairwise. Trade-off: a small cap builds faster and uses less memory,
  /// but leaves get crowded and queries turn quadratic within them.
  int max_depth = 0;

  /// The split threshold: a cube with more than `leaf_size` objects is split (min 1).
  /// Trade-off: small leaves prune more precisely but mean more cubes (memory, build and refit
  /// time, walk steps); large leaves test more object pairs exhaustively. Leaves of up to 8
  /// are tested against each other in one vectorised pass, so 8 gives the fastest self-collide
  /// at a small cost to single-object queries; larger leaves fall back to pair-by-pair tests.
  int leaf_size = 8;

  /// See UpdatePolicy.
  UpdatePolicy update_policy = UpdatePolicy::automatic;

  /// For loops of update() + self-collide (simulations, motion steps): update() and
  /// update(objects) keep the list of overlapping pairs, and a self-collide that follows calls
  /// the callback for those pairs without walking the cubes (as FCL's SaP manager keeps its
  /// pairs). The first such update, and the first after the objects were rearranged
  /// (registrations, removals, setup() rebuilding, update(obj)), lists every pair with one self
  /// walk; later ones query only the objects that moved, and a rebuild inside update() changes
  /// nothing in the list (it holds ids). An update that moved more than a quarter of the
  /// objects drops the list (then self-collide walks), and so does update(obj), so that a loop
  /// of single updates costs no more than without it. Off by default: a const query cannot ask
  /// for the list without hidden mutable state, so the caller says so. Trade-off: each update
  /// costs more (a query per moved object and a pass over the list, or a listing: about a self
  /// walk), which a caller who runs only object queries would pay for nothing; a self-collide
  /// after small motions reads the list instead of walking. 8 bytes per overlapping pair and 8
  /// per object (each object's pointer beside its id, kept while the list is valid). Same
  /// pairs either way; right after a listing in the same order, later the moved objects' pairs
  /// last.
  bool keep_pairs = false;

  /// With UpdatePolicy::automatic: the tree quality (total surface area of the cubes per object
  /// over its value right after the last build) past which the cubes may be rebuilt (must be
  /// > 1). Insertions and removals rebuild as soon as the quality exceeds it; updates, once it
  /// exceeds it and `rebuild_budget` is spent too. Trade-off: a low value rebuilds
  /// often (a build costs many refits); a high value lets queries slow down on a stale tree. The
  /// default is where the drift benchmark (benchmarks/bench_drift.cpp, its figures in
  /// docs/tuning.md) found update + queries fastest. With keep_pairs, a self-collide
  /// after small motions reads the pair list instead of walking, so higher values can pay off
  /// for update + self-collide, at the cost of object queries on a looser tree.
  double rebuild_threshold = 1.25;

  /// With UpdatePolicy::automatic: an update rebuilds only once the quality exceeds
  /// `rebuild_threshold` and the stale tree's predicted cost, summed over the updates since the
  /// last build (each update(), update(obj) and update(objects) call counts as one walk),
  /// exceeds this many builds (>= 0): rent or buy. A walk's predicted loss is the quality minus
  /// 1 times the cost of a walk in builds, which the last build estimated from how crowded its
  /// leaves are (up to two builds where objects crowd, a sixth of one where they are sparse). 1
  /// (the default) rebuilds when the loss predicted since the build equals one build; 0
  /// rebuilds as soon as the quality exceeds rebuild_threshold. Trade-off: a large budget keeps
  /// refitting (cheap updates) while every walk runs on the stretched tree; a small one
  /// rebuilds sooner, which costs more when several updates come between walks. The prediction
  /// is for one self-collide per update: with many queries between updates, a lower budget
  /// pays; with several updates per query, a higher one (docs/tuning.md).
  double rebuild_budget = 1.0;

  /// Objects whose AABB has a coordinate beyond +-unbounded_limit (or infinite: planes,
  /// halfspaces) are kept out of the cubes in a separate list that every query tests. Trade-off:
  /// a huge object inside the cubes would make every cube above it huge and useless for pruning;
  /// in the list it costs one box test per query and per object in self-collide.
  double unbounded_limit = 1e15;

  /// Self-collide of a scene of at most this many objects (0 to kMaxAllPairsLimit; slots left
  /// by unregistered objects count until they are reused or compacted away), and collide of two
  /// managers that both hold at most this many, skip the cubes and test every pair of objects,
  /// 8 (AVX2) or 4 (SSE2) pairs per instruction, then the pairs that pass exactly (between two
  /// managers, only the objects that reach the other's root cube). Trade-off: the pair tests
  /// grow with the square of the scene, the walk down the cubes only a little faster than the
  /// scene, but at a few dozen objects the walk's fixed cost per call is the larger. 0 always
  /// walks the cubes. Same pairs either way; the order of the callbacks differs.
  std::size_t all_pairs_limit = 64;
  /// Upper bound of all_pairs_limit.
  static constexpr std::size_t kMaxAllPairsLimit = 64;

  /// collide() in all three forms leaves out the pairs whose tight bounding volumes (the
  /// bounding sphere, exact for spheres, and the oriented box of the geometry's local AABB,
  /// exact for boxes; on the records of tight_volumes also the capsule about a capsule's,
  /// cylinder's or cone's axis) are apart by more than a margin sized for FCL's default GJK
  /// tolerance (1e-6): such pairs cannot collide, and the callback never sees them. The default
  /// callbacks of cube_collision/callbacks.h do this anyway. Turn it on when your callback runs
  /// fcl::collide with gjk_tolerance <= 1e-6 and keeps only what collides: its results stay the
  /// same and it runs for fewer pairs. Leave it off if your callback counts or records
  /// broadphase pairs, grows the AABBs for a contact margin (pairs near but not touching would
  /// be lost) or asks for costs. Planes, halfspaces and octrees are never left out. The volumes
  /// come from the per-object records where the manager keeps them (tight_volumes). Trade-off:
  /// a few dozen flops per pair whose boxes overlap, against a narrow-phase call of about a
  /// microsecond or more for each pair proved apart (three in four of the boxes' pairs in the
  /// benchmark's scenes). Distance queries are not affected.
  bool cull_pairs = false;

  /// Lets the manager keep each object's tight volumes (bounding sphere, oriented box of its
  /// local AABB, a ball inside primitives; for capsules, cylinders and cones the capsule about
  /// their axis, and capsules and boxes inside spheres, boxes, capsules and cylinders) in float
  /// records per object, so that the pipeline (queries.h, batch.h) and Config::cull_pairs bound a
  /// candidate pair by reading two records instead of two FCL objects and their geometries. They
  /// are built only when needed: by the first such query of a manager, from the objects as they
  /// are then (one pass over the objects, counted by the "first" case of
  /// benchmarks/instructions.sh); a manager used only through FCL's interface with its own
  /// callbacks never builds them. Once built, registration builds an object's records from the
  /// geometry and the transform. In a manager of 256 objects or more, update(obj) /
  /// update(objects) build them again too, and update() places them anew for each object whose
  /// box changed (reading its geometry again only if its local AABB changed). In a smaller one
  /// (a robot's links, which move at every step) an update that moves an object leaves its
  /// records stale instead, and its pairs are culled from the object as without records, until
  /// an update() finds its box standing and builds them again. Either way update() places them
  /// anew for an object whose box stands but whose transform no longer rounds to the same floats
  /// (a rotation may leave FCL's box as it was). So move objects, update, then query, as for the
  /// boxes; and after changing a geometry in place in a way that leaves its local AABB as it was
  /// (another radius of a capsule of the same box, the cost density), name its object to
  /// update(obj). CubeCollisionManager::dropVolumes() frees
  /// them. Trade-off, once built: memory per object, and update() reads every object's transform
  /// and registration builds the records, against a cull several times cheaper per candidate pair
  /// (figures in benchmarks/README.md). Off: the pipeline (and Config::cull_pairs) culls from the
  /// objects, with the same answers (the objects' cull has the spheres, boxes and inscribed balls
  /// only: more pairs go to FCL).
  bool tight_volumes = true;

  /// Hands every pair over in an order that does not depend on the tree: in self queries as
  /// (earlier registered, later registered), and the callbacks of a collide sorted by the
  /// registration numbers of the pair (object queries: of the managed object; manager against
  /// manager: of this manager's object, then the other's). Two managers that registered the
  /// same objects in the same order then make the same calls in the same order, however their
  /// trees were built, rebuilt or refitted; FCL's narrow phase, which is not symmetric, then
  /// gives the same contacts. Distance queries keep their nearest-first order (the bound needs
  /// it) but orient self pairs the same way. Trade-off: a collide gathers its pairs and sorts
  /// them before the first callback (a sort of the pairs), so a callback's `true` no longer
  /// saves the rest of the walk; QueryStats then count no box tests.
  bool canonical_pairs = false;

  /// Filter groups (objects with equal filter bits, CubeCollisionManager::setFilter) that the
  /// cubes keep apart. When at most this many groups are in use and some two of them (or one
  /// with itself) cannot pair, a build splits a cube holding several groups between groups
  /// before any median split, and each cube records the group of its objects: a walk then drops
  /// a pair of cubes whose groups cannot pair, and tests no bits within pairs of one-group
  /// leaves that can (a static scene whose objects do not pair with each other costs only its
  /// pairs with the moving ones). Groups are laid out by builds: after bits change, the next
  /// update() or setup() rebuilds; until then every pair is tested bit by bit. 0: off, at most
  /// 64. Trade-off: each group spans the whole scene, so an object query descends one subtree
  /// per group, and pairs of groups that do pair are walked as separate subtrees, which
  /// overlap; past a few groups that costs more than the dropped pairs save.
  int filter_groups = 8;

  /// Throws std::invalid_argument naming the first knob out of range.
  void check() const;
};

}  // namespace cube
