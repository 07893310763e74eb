//! Pictures of airglyph's measurements, drawn alike on every machine.
//!
//! plotters draws text with a system font it finds through fontconfig, which a headless
//! device may not have (`eval-pose --plots` then failed with `NoSuchFont("sans-serif")`).
//! Here DejaVu Sans is built in (fonts/README.md says which and under what licence) and
//! registered as `sans-serif`, the family of plotters' own text and of airglyph's plots.
//! And a picture is drawn in memory and written whole, under its name only once it is
//! complete: a drawing that fails leaves no file, or the old one untouched.
//!
//! ```no_run
//! use plotters::prelude::*;
//! airglyph_plot::png(std::path::Path::new("errors.png"), (800, 400), |root| {
//!     let mut chart = ChartBuilder::on(root)
//!         .caption("error per frame", ("sans-serif", 22))
//!         .build_cartesian_2d(0.0..10.0, 0.0..5.0)?;
//!     chart.configure_mesh().draw()?;
//!     Ok(())
//! })?;
//! # Ok::<(), airglyph_plot::PlotError>(())
//! ```

#![warn(missing_docs)]

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// What a picture is drawn on: its whole area, white.
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// What drawing returns: any of plotters' errors (which differ by what they draw on).
pub type DrawResult = Result<(), Box<dyn std::error::Error + Send + Sync>>;

/// A picture that could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {}: {reason}", path.display())]
pub struct PlotError {
    /// The picture's file.
    pub path: PathBuf,
    /// What plotters or the file system said.
    pub reason: String,
}

/// DejaVu Sans 2.37 (fonts/README.md).
const DEJAVU_SANS: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// Registers the built-in font as `sans-serif`, once a process.
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let registered =
            plotters::style::register_font("sans-serif", FontStyle::Normal, DEJAVU_SANS);
        assert!(registered.is_ok(), "the built-in font is a TrueType font");
    });
}

/// Draws a `width`×`height` picture with `draw` and writes it to `path` as a PNG, whole.
pub fn png(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(&Area) -> DrawResult,
) -> Result<(), PlotError> {
    register_font();
    let fail = |reason: String| PlotError {
        path: path.to_owned(),
        reason,
    };
    let mut pixels = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (width, height)).into_drawing_area();
        root.fill(&WHITE)
            .map_err(|e| e.into())
            .and_then(|()| draw(&root))
            .and_then(|()| root.present().map_err(|e| e.into()))
            .map_err(|e| fail(e.to_string()))?;
    }
    let picture = image::RgbImage::from_raw(width, height, pixels).expect("sized to the picture");
    let mut encoded = std::io::Cursor::new(Vec::new());
    picture
        .write_to(&mut encoded, image::ImageFormat::Png)
        .map_err(|e| fail(e.to_string()))?;
    airglyph_core::file::write_whole(path, encoded.into_inner()).map_err(|e| fail(e.to_string()))
}

/// The size of a confusion matrix's labels, and the most a character of them takes.
const LABEL_FONT_PX: u32 = 13;
const LABEL_CHAR_PX: u32 = 8;

/// Draws a confusion matrix `m[truth][predicted]` over `labels` as a PNG heat map, each
/// row normalized (white to dark blue, by the square root so small confusions show),
/// with the counts written in the cells when `counts`.
pub fn confusion(
    path: &Path,
    title: &str,
    labels: &[String],
    m: &[Vec<u32>],
    counts: bool,
) -> Result<(), PlotError> {
    let n = labels.len().max(1);
    let cell = if n <= 12 { 56 } else { 24 };
    // Labels wider than a cell (a vocabulary of words, not of symbols) would run into
    // each other under the columns: they are written downwards, and the margins fit them.
    let longest = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32;
    let label_px = LABEL_CHAR_PX * longest + 12;
    let upright = label_px > cell;
    let (x_area, y_area) = (
        if upright { label_px + 20 } else { 40 },
        label_px.max(58) + 12,
    );
    let size = (
        cell * n as u32 + y_area + 70,
        cell * n as u32 + x_area + 110,
    );
    png(path, size, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(x_area)
            .y_label_area_size(y_area)
            .build_cartesian_2d((0..n - 1).into_segmented(), (0..n - 1).into_segmented())?;
        let (lx, ly) = (labels.to_vec(), labels.to_vec());
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(n)
            .y_labels(n)
            .x_label_style(("sans-serif", LABEL_FONT_PX))
            .y_label_style(("sans-serif", LABEL_FONT_PX))
            .x_desc("predicted")
            .y_desc("true")
            // (Upright labels are drawn below; asking plotters for no labels at all
            // loops forever in its key points.)
            .x_label_formatter(&move |v| match v {
                SegmentValue::CenterOf(i) if !upright => lx.get(*i).cloned().unwrap_or_default(),
                _ => String::new(),
            })
            .y_label_formatter(&move |v| match v {
                SegmentValue::CenterOf(i) if *i < n => {
                    ly.get(n - 1 - *i).cloned().unwrap_or_default()
                }
                _ => String::new(),
            })
            .draw()?;
        let mut rects = Vec::new();
        let mut texts = Vec::new();
        for (i, row) in m.iter().enumerate().take(n) {
            let total = row.iter().sum::<u32>().max(1);
            for (j, &c) in row.iter().enumerate().take(n) {
                let s = (c as f64 / total as f64).sqrt();
                let colour = RGBColor(
                    (255.0 * (1.0 - s)) as u8,
                    (255.0 * (1.0 - 0.8 * s)) as u8,
                    255,
                );
                let y = n - 1 - i;
                rects.push(Rectangle::new(
                    [
                        (SegmentValue::Exact(j), SegmentValue::Exact(y)),
                        (SegmentValue::Exact(j + 1), SegmentValue::Exact(y + 1)),
                    ],
                    colour.filled(),
                ));
                if counts {
                    let ink = if s > 0.6 { WHITE } else { BLACK };
                    texts.push(Text::new(
                        format!("{c}"),
                        (SegmentValue::CenterOf(j), SegmentValue::CenterOf(y)),
                        ("sans-serif", 14).into_font().color(&ink),
                    ));
                }
            }
        }
        chart.draw_series(rects)?;
        chart.draw_series(texts)?;
        if upright {
            // Under each column, reading downwards from just below the matrix.
            let style = ("sans-serif", LABEL_FONT_PX)
                .into_font()
                .transform(FontTransform::Rotate90);
            for (j, label) in labels.iter().enumerate() {
                let (x, y) =
                    chart.backend_coord(&(SegmentValue::CenterOf(j), SegmentValue::Exact(0)));
                root.draw(&Text::new(
                    label.clone(),
                    (x + LABEL_FONT_PX as i32 / 2, y + 9),
                    style.clone(),
                ))?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_with_the_built_in_font() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("text.png");
        png(&path, (200, 60), |root| {
            root.draw(&Text::new("Ag 4.1 cm", (10, 10), ("sans-serif", 30)))?;
            Ok(())
        })
        .unwrap();
        let picture = image::open(&path).unwrap().to_rgb8();
        let inked = picture.pixels().filter(|p| p.0[0] < 128).count();
        // Nine glyphs at 30 px ink a few hundred pixels; a missing font none at all.
        assert!(inked > 200, "{inked} dark pixels");
    }

    /// Rows below the matrix's last cell with grey ink (text) in them.
    fn rows_inked_below_the_matrix(path: &Path) -> usize {
        let picture = image::open(path).unwrap().to_rgb8();
        let row_has = |y: u32, f: &dyn Fn(&image::Rgb<u8>) -> bool| {
            (0..picture.width()).any(|x| f(picture.get_pixel(x, y)))
        };
        let blue = |p: &image::Rgb<u8>| p.0[2] == 255 && p.0[0] < 100;
        let grey = |p: &image::Rgb<u8>| {
            let (lo, hi) = (p.0.iter().min().unwrap(), p.0.iter().max().unwrap());
            *hi < 160 && hi - lo < 30
        };
        let bottom = (0..picture.height()).rfind(|&y| row_has(y, &blue)).unwrap();
        (bottom + 3..picture.height())
            .filter(|&y| row_has(y, &grey))
            .count()
    }

    #[test]
    fn labels_wider_than_a_column_are_written_upright_and_whole() {
        let dir = tempfile::tempdir().unwrap();
        let m = vec![vec![3, 1, 0], vec![0, 4, 0], vec![1, 0, 3]];
        let words: Vec<String> = ["circle-side", "zigzag-deep", "helix-out"]
            .map(String::from)
            .to_vec();
        let path = dir.path().join("words.png");
        confusion(&path, "words", &words, &m, true).unwrap();
        // Eleven characters written downwards: ink some 70 rows tall, and the axis's
        // name (written across, the labels ran into each other in one line's height).
        let rows = rows_inked_below_the_matrix(&path);
        assert!(rows > 60, "{rows} rows");
        let symbols: Vec<String> = ["0", "O", "Q"].map(String::from).to_vec();
        let path = dir.path().join("symbols.png");
        confusion(&path, "symbols", &symbols, &m, true).unwrap();
        let rows = rows_inked_below_the_matrix(&path);
        assert!(rows < 35, "{rows} rows");
    }

    #[test]
    fn a_failed_drawing_leaves_the_old_picture_and_no_part_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.png");
        std::fs::write(&path, b"the old picture").unwrap();
        let err = png(&path, (100, 100), |_| Err("no data to draw".into())).unwrap_err();
        assert!(err.to_string().contains("no data to draw"), "{err}");
        assert!(err.to_string().contains("plot.png"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"the old picture");
        let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(files.len(), 1, "{files:?}");
    }
}
