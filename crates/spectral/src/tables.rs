//! The embedded CSV tables, parsed once on first use.
//!
//! The files are copied verbatim from the project's data set (see `data/SOURCES.md` for sources and units) and
//! compiled into the binary, so nothing is read from disk at run time.

use std::sync::OnceLock;

/// A parsed CSV table: the header's column names and the numeric rows.
pub(crate) struct Table {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    /// Index of the column called `name`.
    pub fn column_index(&self, name: &str) -> usize {
        self.columns.iter().position(|c| c == name).unwrap_or_else(|| panic!("embedded table has no column '{name}'"))
    }

    /// All values of the column called `name`.
    pub fn column(&self, name: &str) -> Vec<f64> {
        let i = self.column_index(name);
        self.rows.iter().map(|r| r[i]).collect()
    }
}

/// Parses an all-numeric CSV with one header row. Embedded tables are part of the program, so a malformed one is
/// a build defect (caught by the tests), not a user error: it panics with the table's name.
pub(crate) fn parse_numeric_csv(name: &str, text: &str) -> Table {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header = lines.next().unwrap_or_else(|| panic!("embedded table {name} is empty"));
    let columns: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
    let rows = lines
        .enumerate()
        .map(|(i, line)| {
            let row: Vec<f64> = line
                .split(',')
                .map(|f| {
                    f.trim()
                        .parse::<f64>()
                        .unwrap_or_else(|e| panic!("embedded table {name}, row {}: '{f}': {e}", i + 2))
                })
                .collect();
            assert_eq!(row.len(), columns.len(), "embedded table {name}, row {}", i + 2);
            row
        })
        .collect();
    Table { columns, rows }
}

macro_rules! embedded_table {
    ($fn_name:ident, $file:literal) => {
        pub(crate) fn $fn_name() -> &'static Table {
            static CELL: OnceLock<Table> = OnceLock::new();
            CELL.get_or_init(|| parse_numeric_csv($file, include_str!(concat!("../data/", $file))))
        }
    };
}

embedded_table!(cie1931, "cie1931_2deg_xyz.csv");
embedded_table!(cie1964, "cie1964_10deg_xyz.csv");
embedded_table!(stiles_burch, "stiles_burch_1959_10deg_rgb.csv");
embedded_table!(illuminants, "cie_illuminants.csv");
embedded_table!(fluorescent, "cie_fluorescent_illuminants.csv");
embedded_table!(daylight_basis, "cie_daylight_basis.csv");
embedded_table!(camera_sensors, "camera_sensors.csv");
embedded_table!(colorchecker, "colorchecker_babelcolor_average.csv");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_parse_with_documented_shapes() {
        assert_eq!(cie1931().rows.len(), 471);
        assert_eq!(cie1964().rows.len(), 471);
        assert_eq!(stiles_burch().rows.len(), 89);
        assert_eq!(illuminants().rows.len(), 107);
        assert_eq!(fluorescent().columns.len(), 13);
        assert_eq!(daylight_basis().rows.len(), 107);
        // Column sums of the 1931 observer quoted in the data README.
        let t = cie1931();
        let sums: Vec<f64> = ["x_bar", "y_bar", "z_bar"].iter().map(|c| t.column(c).iter().sum()).collect();
        assert!((sums[0] - 106.866).abs() < 1e-3, "{sums:?}");
        assert!((sums[1] - 106.857).abs() < 1e-3, "{sums:?}");
        assert!((sums[2] - 106.892).abs() < 1e-3, "{sums:?}");
    }
}
