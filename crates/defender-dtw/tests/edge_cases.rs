//! Edge cases and errors at the API boundary.
#![allow(clippy::unwrap_used)] // test helpers outside #[test] fns: a panic is a failed test

mod common;

use common::{close, naive_dtw};
use defender_dtw::{Dtw, DtwError, QueryWindow, RefWindow, References, View, dtw};

#[test]
fn length_one_sequences() {
    let d = dtw(&[1.0, 2.0], &[4.0, 6.0], 2, &Dtw::euclidean()).unwrap();
    assert_eq!(d, 5.0);
    let y = [0.0, 1.0, 2.0, 3.0];
    let d = dtw(&[1.0], &y, 1, &Dtw::euclidean()).unwrap();
    assert_eq!(d, 1.0 + 0.0 + 1.0 + 2.0);
    assert_eq!(dtw(&y, &[1.0], 1, &Dtw::euclidean()).unwrap(), 4.0);
}

#[test]
fn identical_sequences_cost_zero() {
    let x: Vec<f32> = (0..300 * 7).map(|i| (i as f32 * 0.1).cos()).collect();
    assert_eq!(dtw(&x, &x, 7, &Dtw::euclidean()).unwrap(), 0.0);
    assert_eq!(dtw(&x, &x, 7, &Dtw::euclidean().with_band(0)).unwrap(), 0.0);
    let refs = References::new(7, &[&x[..], &x[..70 * 7]]).unwrap();
    let mut stream = refs.stream(&[View::new(QueryWindow::All, RefWindow::MatchQuery)]).unwrap();
    for xt in x.chunks_exact(7).take(10) {
        stream.push(xt).unwrap();
    }
    // x[..10] vs y[-10:] differ; after 70 pushes x equals the second reference.
    assert!(stream.costs(0)[0] > 0.0);
    let mut stream = refs.stream(&[View::new(QueryWindow::All, RefWindow::All)]).unwrap();
    for xt in x.chunks_exact(7).take(10) {
        stream.push(xt).unwrap();
    }
    assert!(stream.costs(0).iter().all(|&c| c > 0.0));
    for xt in x.chunks_exact(7).skip(10).take(60) {
        stream.push(xt).unwrap();
    }
    assert_eq!(stream.costs(0)[1], 0.0);
}

#[test]
fn band_narrower_than_length_difference_is_infinite() {
    let x = [0.0, 1.0, 2.0, 3.0, 4.0];
    let y = [0.0, 4.0];
    assert_eq!(dtw(&x, &y, 1, &Dtw::euclidean().with_band(2)).unwrap(), f32::INFINITY);
    let got = dtw(&x, &y, 1, &Dtw::euclidean().with_band(3)).unwrap();
    assert!(close(got, naive_dtw(&x, &y, 1, Some(3))));
}

#[test]
fn errors_at_the_boundary() {
    let s = Dtw::euclidean();
    assert_eq!(dtw(&[1.0], &[1.0], 0, &s), Err(DtwError::ZeroDimension));
    assert!(matches!(dtw(&[], &[1.0], 1, &s), Err(DtwError::EmptySequence { .. })));
    assert!(matches!(dtw(&[1.0, 2.0, 3.0], &[1.0, 2.0], 2, &s), Err(DtwError::LengthNotMultiple { .. })));
    assert!(matches!(dtw(&[1.0, f32::NAN], &[1.0, 2.0], 2, &s), Err(DtwError::NonFinite { index: 1, .. })));
    assert!(matches!(dtw(&[1.0], &[f32::INFINITY], 1, &s), Err(DtwError::NonFinite { index: 0, .. })));
    assert!(matches!(
        dtw(&[1.0], &[1.0], 1, &s.with_max_cost(f32::NAN)),
        Err(DtwError::InvalidSetting { .. })
    ));

    assert_eq!(References::new(2, &[]).unwrap_err(), DtwError::NoReferences);
    let err = References::new(2, &[&[1.0, 2.0], &[1.0, 2.0, 3.0]]).unwrap_err();
    assert!(err.to_string().contains("reference 1"), "{err}");
    assert!(matches!(References::new(1, &[&[f32::NAN]]), Err(DtwError::NonFinite { .. })));

    let refs = References::new(2, &[&[1.0, 2.0]]).unwrap();
    let bad = View::new(QueryWindow::Last(0), RefWindow::All);
    assert!(matches!(refs.stream(&[bad]), Err(DtwError::InvalidSetting { .. })));
    let mut stream = refs.stream(&[View::new(QueryWindow::All, RefWindow::All)]).unwrap();
    assert_eq!(stream.costs(0), &[f32::INFINITY]);
    assert!(matches!(stream.push(&[1.0]), Err(DtwError::DimensionMismatch { expected: 2, got: 1, .. })));
    assert!(matches!(stream.push(&[1.0, f32::NEG_INFINITY]), Err(DtwError::NonFinite { .. })));
    assert!(stream.is_empty(), "a refused push leaves the state unchanged");
    stream.push(&[1.0, 3.0]).unwrap();
    assert_eq!(stream.costs(0), &[1.0]);
    assert_eq!(stream.get_costs(1), None);
    let mut out = vec![0.0; 2];
    assert!(matches!(
        refs.align_view_into(&[1.0, 2.0], &View::new(QueryWindow::All, RefWindow::All), &s, &mut out),
        Err(DtwError::DimensionMismatch { .. })
    ));
}
