//! The hierarchy against the brute-force reference, its invariants and
//! its parts.

use super::build::{down, in_leaf_order, up};
use super::bundle::{bundle, fan};
use super::*;
use crate::accel::BruteForce;
use crate::kernels::EdgeCone;
use crate::scene::{Coverage, Straddle, TriangleFan, bundle_cone};
use crate::scene::{Material, Primitive, Shape, SurfaceClass, Triangle};
use proptest::prelude::*;

fn random_scene(seed: u64, n: usize) -> Scene {
    let mut s = crate::rng::Stream::new(seed, 0, 0, crate::rng::Purpose::Test);
    let mut scene = Scene::default();
    let m = scene.add_material(Material {
        name: "m".into(),
        reflectance: 0.5,
        incidence_exponent: 1.0,
        spectrum: Vec::new(),
    });
    let o = scene.add_object("soup");
    for _ in 0..n {
        let c = DVec3::new(
            s.uniform() * 200.0 - 100.0,
            s.uniform() * 200.0 - 100.0,
            s.uniform() * 30.0,
        );
        let r = |s: &mut crate::rng::Stream| {
            DVec3::new(s.uniform() - 0.5, s.uniform() - 0.5, s.uniform() - 0.5) * 8.0
        };
        if let Some(t) = Triangle::new(c + r(&mut s), c + r(&mut s), c + r(&mut s)) {
            scene.primitives.push(Primitive {
                shape: Shape::Triangle(t),
                material: m,
                class: SurfaceClass::Unclassified,
                object: o,
            });
        }
    }
    scene
}

#[test]
fn valid_on_random_and_degenerate_scenes() {
    for n in [0, 1, 3, 5, 17, 1000] {
        let bvh = Bvh::build(random_scene(n as u64, n));
        bvh.validate().unwrap();
    }
    // Many identical triangles: centroids coincide.
    let mut scene = random_scene(1, 1);
    let p = scene.primitives[0].clone();
    scene.primitives = vec![p; 100];
    let bvh = Bvh::build(scene);
    bvh.validate().unwrap();
    assert!(bvh.stats().max_depth < STACK);
}

/// A scene large enough for the top levels to be built in parallel,
/// each subtree in its own part of the node array: the hierarchy is
/// valid and finds what testing every primitive finds.
#[test]
fn parallel_build_is_valid_and_finds_every_hit() {
    let n = 3 * PARALLEL_MIN;
    let bvh = Bvh::build(random_scene(11, n));
    bvh.validate().unwrap();
    let stats = bvh.stats();
    assert!(stats.leaves >= n / MAX_LEAF, "{stats:?}");
    let brute = BruteForce::new(bvh.scene().clone());
    let mut s = crate::rng::Stream::new(11, 1, 0, crate::rng::Purpose::Test);
    let mut hits = 0;
    for _ in 0..2000 {
        let o = DVec3::new(
            s.uniform() * 240.0 - 120.0,
            s.uniform() * 240.0 - 120.0,
            500.0,
        );
        let d = DVec3::new(s.uniform() - 0.5, s.uniform() - 0.5, -2.0);
        let ray = Ray::new(o, d);
        let (a, b) = (
            brute.closest_hit(&ray, 0.0, 1e9),
            bvh.closest_hit(&ray, 0.0, 1e9),
        );
        assert_eq!(a.map(|h| (h.prim, h.t)), b.map(|h| (h.prim, h.t)));
        hits += usize::from(a.is_some());
    }
    assert!(hits > 500, "{hits}");
}

/// A leaf's box is the tightest padded `f32` box around the `f64` union of
/// its primitives' boxes, though the build unites boxes already rounded
/// to `f32` one primitive at a time.
#[test]
fn leaf_boxes_are_the_rounded_union_of_their_primitives() {
    let bvh = Bvh::build(scene_with_trees(5));
    let pad = DVec3::splat(bvh.pad);
    let mut leaves = 0;
    for node in &bvh.nodes {
        for slot in (0..WIDTH).filter(|&s| node.count[s] > 0) {
            let first = node.child[slot] as usize;
            let prims = &bvh.scene.primitives[first..first + node.count[slot] as usize];
            let union = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds()));
            let (lo, hi) = (union.min - bvh.origin - pad, union.max - bvh.origin + pad);
            let want = [
                down(lo.x),
                down(lo.y),
                down(lo.z),
                up(hi.x),
                up(hi.y),
                up(hi.z),
            ];
            let got = [0, 1, 2, 3, 4, 5].map(|row| node.planes[row][slot]);
            assert_eq!(got, want, "leaf at {first}");
            leaves += 1;
        }
    }
    assert!(leaves > 10, "{leaves}");
}

/// A triangle soup with trees standing in it.
/// Triangles, and horizontal rectangles (polygons, which carry no
/// normal from the bundle test) at random heights, some of them tilted.
fn scene_with_polygons(seed: u64) -> Scene {
    let mut scene = random_scene(seed, 200);
    let mut s = crate::rng::Stream::new(seed, 2, 0, crate::rng::Purpose::Test);
    let (m, o) = (0, 0);
    for _ in 0..30 {
        let c = DVec3::new(
            s.uniform() * 200.0 - 100.0,
            s.uniform() * 200.0 - 100.0,
            0.0,
        );
        let (w, z, tilt) = (
            5.0 + 20.0 * s.uniform(),
            40.0 * s.uniform(),
            s.uniform() - 0.5,
        );
        let corner = |x: f64, y: f64| c + DVec3::new(x * w, y * w, z + tilt * x * w);
        let poly = crate::scene::Polygon::new(vec![
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
        ])
        .expect("a planar rectangle");
        scene.primitives.push(Primitive {
            shape: Shape::Polygon(Box::new(poly)),
            material: m,
            class: SurfaceClass::Unclassified,
            object: o,
        });
    }
    scene
}

fn scene_with_trees(seed: u64) -> Scene {
    let mut scene = random_scene(seed, 300);
    let mut s = crate::rng::Stream::new(seed, 1, 0, crate::rng::Purpose::Test);
    for k in 0..40 {
        let base = DVec3::new(s.uniform() * 160.0 - 80.0, s.uniform() * 160.0 - 80.0, 0.0);
        let spec = crate::scene::TreeSpec::new(
            base,
            crate::scene::Species::Pine,
            0.3,
            15.0 + 10.0 * s.uniform(),
            6.0,
        );
        scene.add_tree(
            &spec,
            &crate::scene::FoliageSettings::default(),
            format!("tree {k}"),
        );
    }
    scene
}

/// The leaf-order gather puts at `i` the item `order[i]` named, for
/// permutations of every cycle structure.
#[test]
fn leaf_order_gathers_the_named_elements() {
    let mut s = crate::rng::Stream::new(3, 0, 0, crate::rng::Purpose::Test);
    for n in [0usize, 1, 2, 3, 10, 257] {
        for _ in 0..20 {
            let mut order: Vec<u32> = (0..n as u32).collect();
            // Fisher–Yates, sometimes stopped early (fixed points).
            let swaps = (s.uniform() * n as f64) as usize;
            for i in (1..n).rev().take(swaps) {
                let j = (s.uniform() * (i + 1) as f64) as usize;
                order.swap(i, j.min(i));
            }
            let items: Vec<u64> = (0..n as u64).map(|i| 1000 + i * i).collect();
            let want: Vec<u64> = order.iter().map(|&i| items[i as usize]).collect();
            let got = in_leaf_order(items.clone(), &order);
            assert_eq!(got, want);
        }
    }
}

/// A leaf order that names an element twice (and so misses one) is refused
/// rather than gathered.
#[test]
#[should_panic(expected = "permutation")]
fn leaf_order_must_be_a_permutation() {
    in_leaf_order(vec![1, 2, 3], &[0, 2, 2]);
}

/// The bundle's box test never leaves out a box one of its rays
/// enters before `t_max` (tested ray by ray with the f64 slab test),
/// for bundles of every sign pattern; and the bundle's sum and cone are
/// those of its directions.
#[test]
fn bundle_box_test_keeps_every_box_a_ray_enters() {
    let mut s = crate::rng::Stream::new(9, 0, 0, crate::rng::Purpose::Test);
    let mut u = move || s.uniform() - 0.5;
    let (mut entered, mut missed) = (0, 0);
    for case in 0..20_000 {
        let c = DVec3::new(u(), u(), u()).normalize();
        let spread = [1e-4, 0.05, 0.6][case % 3];
        let dirs: Vec<DVec3> = (0..7)
            .map(|_| (c + DVec3::new(u(), u(), u()) * spread).normalize())
            .collect();
        let o = DVec3::new(u(), u(), u()) * 50.0;
        let (slabs, sum) = bundle(o, &dirs);
        assert_eq!(sum, dirs.iter().fold(DVec3::ZERO, |s, d| s + *d));
        assert_eq!(bundle_cone(&dirs, sum), crate::scene::bundle_spread(&dirs));
        // Boxes near the bundle's axis, behind the origin or ahead of it,
        // in the slots of a node; the last slot of every third node is
        // left empty.
        let mut node = WideNode::EMPTY;
        for slot in 0..WIDTH - usize::from(case % 3 == 0) {
            let near = o + c * (u() * 200.0) + DVec3::new(u(), u(), u()) * 30.0;
            let size =
                DVec3::new(u() + 0.5, u() + 0.5, u() + 0.5) * [0.0, 1.0, 20.0][(case + slot) % 3];
            let (a, b) = (near - size, near + size);
            for k in 0..3 {
                node.planes[k][slot] = down(a[k]);
                node.planes[3 + k][slot] = up(b[k]);
            }
        }
        let t_max = [1e3f32, 60.0][case % 2];
        let (mask, t) = slabs.enters(&node.planes, t_max);
        for (slot, &t_slot) in t.iter().enumerate() {
            let b = Aabb {
                min: DVec3::from([0, 1, 2].map(|k| node.planes[k][slot] as f64)),
                max: DVec3::from([0, 1, 2].map(|k| node.planes[3 + k][slot] as f64)),
            };
            let entering = (!b.is_empty())
                .then_some(&dirs)
                .into_iter()
                .flatten()
                .filter_map(|d| b.ray_interval(&Ray { origin: o, dir: *d }, 0.0, t_max as f64))
                .map(|(t0, _)| t0)
                .reduce(f64::min);
            if let Some(t0) = entering {
                assert!(mask & (1 << slot) != 0, "case {case} slot {slot}");
                assert!(t_slot as f64 <= t0 * (1.0 + 1e-5) + 1e-5, "case {case}");
                entered += 1;
            } else {
                missed += 1;
            }
            if b.is_empty() {
                assert_eq!(
                    mask & (1 << slot),
                    0,
                    "case {case}: an empty slot is entered"
                );
            }
        }
    }
    assert!(entered > 4000 && missed > 4000, "{entered} {missed}");
}

/// The edge planes and coverage the kernel gives are the scene's
/// definition ([`TriangleFan::edges`], [`TriangleFan::coverage`]) to
/// the bit, for bundles that miss, straddle and cover triangles (also
/// degenerate and far ones).
#[test]
fn triangle_coverage_is_the_scenes_definition() {
    let mut s = crate::rng::Stream::new(12, 0, 0, crate::rng::Purpose::Test);
    let mut u = move || s.uniform() - 0.5;
    let mut seen = [0usize; 3];
    for case in 0..20_000 {
        let origin = DVec3::new(u(), u(), u()) * 1000.0 + DVec3::Z * 500.0;
        let axis = DVec3::new(u() * 0.8, u() * 0.8, -1.0).normalize();
        let spread = [0.0, 1e-4, 0.02, 0.3][case % 4];
        let cone = EdgeCone::new(origin, axis, spread);
        // Corners around the point the axis reaches 500 m away, from
        // centimetres to tens of metres apart.
        let at = origin + axis * 500.0;
        let size = [0.05, 1.0, 30.0][case % 3];
        let corner = |u: &mut dyn FnMut() -> f64| at + DVec3::new(u(), u(), u() * 0.2) * size;
        let (a, b) = (corner(&mut u), corner(&mut u));
        let c = if case % 7 == 0 {
            a + (b - a) * 0.5
        } else {
            corner(&mut u)
        };
        let Some(tri) = Triangle::new(a, b, c) else {
            continue;
        };
        let bits = |f: &Option<(TriangleFan, Option<Straddle>)>| {
            f.map(|(fan, straddle)| {
                (
                    fan.edge_normals()
                        .map(|e| [e.x, e.y, e.z].map(f64::to_bits)),
                    straddle,
                )
            })
        };
        let definition = TriangleFan::edges(&tri, origin);
        let want = match definition.coverage(axis, spread) {
            Coverage::None => None,
            Coverage::All => Some((definition, None)),
            Coverage::Some(straddle) => Some((definition, Some(straddle))),
        };
        assert_eq!(bits(&fan(&cone, &tri)), bits(&want), "case {case}");
        seen[match want {
            None => 0,
            Some((_, None)) => 1,
            Some((_, Some(_))) => 2,
        }] += 1;
    }
    assert!(seen.iter().all(|&n| n > 1000), "{seen:?}");
}

/// Directions between the sub-rays `dirs`: within their cone (distance
/// from the mean direction at most the largest sub-ray's) and within their
/// per-axis bounds, the region a bundle traversal searches.
fn between(dirs: &[DVec3], seed: u64) -> Vec<DVec3> {
    let mut s = crate::rng::Stream::new(seed, 9, 0, crate::rng::Purpose::Test);
    let sum = dirs.iter().fold(DVec3::ZERO, |a, d| a + *d);
    let axis = sum / dirs.len() as f64;
    let spread = dirs
        .iter()
        .map(|d| (*d - axis).length())
        .fold(0.0, f64::max);
    let bounds = crate::kernels::direction_bounds(dirs);
    let inside = |d: DVec3| {
        (d - axis).length() <= spread
            && (0..3).all(|a| d[a] >= bounds.lo[a] && d[a] <= bounds.hi[a])
    };
    let (u, v) = (
        axis.any_orthonormal_vector(),
        axis.cross(axis.any_orthonormal_vector()),
    );
    (0..400)
        .map(|_| {
            let (a, b) = (s.uniform() * 2.0 - 1.0, s.uniform() * 2.0 - 1.0);
            (axis + (u * a + v * b) * spread).normalize()
        })
        .filter(|d| inside(*d))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// The bundle traversal gives every sub-ray the hit that tracing it
    /// alone over all primitives gives, and the crowns on its way.
    #[test]
    fn pulse_bundles_match_single_rays(seed in 0u64..1000, ox in -120.0..120.0f64,
                                       oy in -120.0..120.0f64, dx in -0.5..0.5f64,
                                       dy in -0.5..0.5f64, spread in 1e-5..0.2f64) {
        // With crowns (per-ray spans), and with polygons but no
        // volumes (normals filled in after the traversal).
        for scene in [scene_with_trees(seed), scene_with_polygons(seed)] {
            // The hierarchy puts the primitives in leaf order: the
            // reference works on the same order.
            let bvh = Bvh::build(scene);
            let brute = BruteForce::new(bvh.scene().clone());
            let origin = DVec3::new(ox, oy, 300.0);
            let c = DVec3::new(dx, dy, -1.0).normalize();
            let u = c.any_orthonormal_vector();
            let v = c.cross(u);
            // A spiral of 19 directions around the central one.
            let dirs: Vec<DVec3> = (0..19)
                .map(|i| {
                    let r = spread * (i as f64 / 18.0).sqrt();
                    let a = i as f64 * 2.399_963;
                    (c + u * (r * a.cos()) + v * (r * a.sin())).normalize()
                })
                .collect();
            let (mut spans, mut along) = (Vec::new(), Vec::new());
            let mut trace = crate::accel::PulseTrace::default();
            bvh.trace_pulse(origin, &dirs, 0.5, 1e4, &mut trace);
            for (i, d) in dirs.iter().enumerate() {
                let ray = Ray { origin, dir: *d };
                let want = brute.trace(&ray, 0.5, 1e4, &mut spans);
                let got = trace.hit(i);
                prop_assert_eq!(want.map(|h| h.prim), got.map(|h| h.prim));
                // Same arithmetic: the same distances, to the bit.
                prop_assert_eq!(want.map(|h| h.t), got.map(|h| h.t));
                prop_assert_eq!(want.map(|h| h.normal), got.map(|h| h.normal));
                // The pulse's volumes hold every crown the sub-ray crosses:
                // its spans through them are the single ray's.
                let hit_t = want.map_or(1e4, |h| h.t);
                crate::accel::spans_along(bvh.scene(), trace.volumes(), &ray, 0.5, hit_t, &mut along);
                prop_assert_eq!(&spans[..], &along[..]);
            }
            // The unseen hold every surface that a ray between the
            // sub-rays meets nearer than the farthest closest hit, and
            // none that a sub-ray hits.
            let hit: Vec<u32> = (0..dirs.len()).filter_map(|i| trace.hit(i).map(|h| h.prim)).collect();
            prop_assert!(trace.unseen().iter().all(|p| !hit.contains(p)));
            prop_assert!(trace.unseen().windows(2).all(|w| w[0] < w[1]));
            let far = if hit.len() == dirs.len() {
                (0..dirs.len()).map(|i| trace.range(i)).fold(0.0, f64::max)
            } else {
                1e4
            };
            for d in between(&dirs, seed) {
                let ray = Ray { origin, dir: d };
                for (p, prim) in bvh.scene().primitives.iter().enumerate() {
                    let p = p as u32;
                    if prim.intersect(&ray, 0.5, far).is_some() && !hit.contains(&p) {
                        prop_assert!(trace.unseen().contains(&p), "primitive {} between the sub-rays", p);
                    }
                }
            }
        }
    }

    #[test]
    fn same_answers_as_brute_force(seed in 0u64..1000, ox in -150.0..150.0f64,
                                   oy in -150.0..150.0f64, dx in -0.5..0.5f64,
                                   dy in -0.5..0.5f64) {
        let scene = random_scene(seed, 300);
        let bvh = Bvh::build(scene);
        let brute = BruteForce::new(bvh.scene().clone());
        let ray = Ray::new(DVec3::new(ox, oy, 500.0), DVec3::new(dx, dy, -1.0));
        let a = brute.closest_hit(&ray, 0.0, 1e9);
        let b = bvh.closest_hit(&ray, 0.0, 1e9);
        prop_assert_eq!(a.map(|h| h.prim), b.map(|h| h.prim));
        if let (Some(a), Some(b)) = (a, b) {
            prop_assert!((a.t - b.t).abs() < 1e-9);
        }
    }
}
