//! The twin method's second stage: which views' samples of one row see the
//! same surface point, so that they are shaded as one packet (their shadow and
//! secondary rays then share descents, and the approximations of sections 2.4
//! and 2.5 may share their shading).
//!
//! A pure function of the row's hits and of the projection into the views, so
//! that it is tested on its own.

use crate::math::Vec3;
use crate::rig::Camera;
use crate::rig::View;

use crate::render::sampler::SampleRow;

/// One packet of the shading stage: for each view (lane), the sample of the
/// row it shades, if any.
pub(super) type Group<const K: usize> = [Option<usize>; K];

/// The sample of `row` nearest to where `point` projects in `view`, if any.
///
/// View `v`'s sample of pixel `x` looks along camera column `x + shift_v`
/// (plus its offset in the pixel), so a point that projects to camera column
/// `c` falls in the view's image column `c - shift_v`.
/// `source` is the sample (of another view) that saw `point`: see
/// [`SampleRow::nearest_to_sample`].
pub(in crate::render) fn nearest_sample(
    camera: &Camera,
    row: &SampleRow,
    view: &View,
    point: Vec3,
    source: usize,
) -> Option<usize> {
    let (column, _) = camera.project(point, view.offset)?;
    row.nearest_to_sample(column - view.shift as f64, source)
}

/// Groups the samples of one row. `points[v][i]` is where view `v`'s sample
/// `i` hit (`None`: it hit nothing); `project(v, i, p)` is the sample of view
/// `v`'s row nearest to where `p`, seen by view 0's sample `i`, projects
/// (`nearest_sample`).
///
/// Every sample of view 0 leads a group; its hit is projected into each other
/// view and the sample found there joins the group if it hit something and no
/// earlier group took it. The samples of other views left over follow, one
/// group each. Every sample of every view is in exactly one group.
/// `claimed` is scratch space (one `Vec<bool>` per view, any content).
pub(in crate::render) fn group_row<const K: usize>(
    points: &[Vec<Option<Vec3>>],
    project: impl Fn(usize, usize, Vec3) -> Option<usize>,
    claimed: &mut [Vec<bool>],
    groups: &mut Vec<Group<K>>,
) {
    groups.clear();
    for c in claimed.iter_mut() {
        c.fill(false);
    }
    let views = points.len();
    for (i, hit) in points[0].iter().enumerate() {
        let mut group = [None; K];
        group[0] = Some(i);
        if let Some(point) = *hit {
            for v in 1..views {
                let Some(k) = project(v, i, point) else {
                    continue;
                };
                if !claimed[v][k] && points[v][k].is_some() {
                    claimed[v][k] = true;
                    group[v] = Some(k);
                }
            }
        }
        groups.push(group);
    }
    for (v, claimed) in claimed.iter().enumerate().skip(1) {
        for (i, _) in claimed.iter().enumerate().filter(|(_, &c)| !c) {
            let mut group = [None; K];
            group[v] = Some(i);
            groups.push(group);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(xs: &[Option<f32>]) -> Vec<Option<Vec3>> {
        xs.iter()
            .map(|x| x.map(|x| Vec3::new(x, 0.0, 0.0)))
            .collect()
    }

    /// A projection that moves every point `d` samples (a flat disparity).
    fn shifted(d: i64, width: usize) -> impl Fn(usize, usize, Vec3) -> Option<usize> {
        move |_, _, p| {
            let k = p.x.round() as i64 + d;
            (k >= 0 && (k as usize) < width).then_some(k as usize)
        }
    }

    fn members<const K: usize>(groups: &[Group<K>]) -> Vec<Vec<Option<usize>>> {
        groups.iter().map(|g| g.to_vec()).collect()
    }

    #[test]
    fn every_sample_is_in_exactly_one_group() {
        let mut g = fastrand::Rng::with_seed(7);
        for _ in 0..200 {
            let width = g.usize(1..20);
            let views = g.usize(1..5);
            let points: Vec<Vec<Option<Vec3>>> = (0..views)
                .map(|_| {
                    (0..width)
                        .map(|i| g.bool().then(|| Vec3::new(i as f32, 0.0, 0.0)))
                        .collect()
                })
                .collect();
            let d = g.i64(-3..4);
            let mut claimed = vec![vec![false; width]; views];
            let mut groups = Vec::new();
            group_row::<4>(&points, shifted(d, width), &mut claimed, &mut groups);
            let mut seen = vec![vec![0; width]; views];
            for group in &groups {
                for (v, s) in group.iter().enumerate() {
                    if let Some(i) = s {
                        seen[v][*i] += 1;
                    }
                }
                for s in group.iter().skip(views) {
                    assert_eq!(*s, None, "no lane beyond the views");
                }
            }
            assert!(seen.iter().flatten().all(|&n| n == 1), "{seen:?}");
        }
    }

    #[test]
    fn a_sample_joins_the_group_of_the_point_it_sees() {
        // View 1 sees every point 2 samples to the right of view 0.
        let points = vec![
            row(&[Some(0.0), Some(1.0), None, Some(3.0)]),
            row(&[None, None, Some(0.0), Some(1.0)]),
        ];
        let mut claimed = vec![vec![false; 4]; 2];
        let mut groups = Vec::new();
        group_row::<2>(&points, shifted(2, 4), &mut claimed, &mut groups);
        assert_eq!(
            members(&groups),
            vec![
                vec![Some(0), Some(2)],
                vec![Some(1), Some(3)],
                vec![Some(2), None], // view 0's miss leads a group of its own
                vec![Some(3), None], // projects off the row
                vec![None, Some(0)], // view 1's leftovers, alone
                vec![None, Some(1)],
            ]
        );
    }

    #[test]
    fn a_sample_that_sees_nothing_or_is_taken_is_not_grouped() {
        // Two samples of view 0 project onto one sample of view 1: the first takes it.
        let points = vec![row(&[Some(1.0), Some(1.2)]), row(&[None, Some(1.0)])];
        let mut claimed = vec![vec![false; 2]; 2];
        let mut groups = Vec::new();
        group_row::<2>(&points, shifted(0, 2), &mut claimed, &mut groups);
        assert_eq!(
            members(&groups),
            vec![
                vec![Some(0), Some(1)],
                vec![Some(1), None],
                vec![None, Some(0)]
            ]
        );
    }
}
