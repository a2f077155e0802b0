//! [`Table`], the one way a Markdown table is written (report.md, the pipelines section, docs/GUIDE.md's traffic
//! table): a header row, an alignment row, then rows of cells. Every table spells a row the same way: `| a | b |`, an
//! empty cell `| |`, and a `|` inside a cell written as `/` (it would end the cell).

/// A column's alignment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    /// Text (`---`).
    Left,
    /// Numbers (`--:`).
    Right,
}

/// A Markdown table being written: [`Table::new`] with the columns, [`Table::row`] per row, [`Table::finish`].
#[derive(Clone, Debug)]
pub struct Table {
    text: String,
    columns: usize,
}

impl Table {
    /// A table with these columns (header text and alignment).
    #[must_use]
    pub fn new<S: AsRef<str>>(columns: impl IntoIterator<Item = (S, Align)>) -> Table {
        let columns: Vec<(S, Align)> = columns.into_iter().collect();
        let mut t = Table { text: String::new(), columns: columns.len() };
        t.push(columns.iter().map(|(h, _)| h.as_ref()));
        t.text.push('|');
        for (_, a) in &columns {
            t.text.push_str(match a {
                Align::Left => "---|",
                Align::Right => "--:|",
            });
        }
        t.text.push('\n');
        t
    }

    /// Appends a row of cells, as many as the columns.
    ///
    /// # Panics
    /// When the row has another number of cells (a table written wrong, not input).
    pub fn row<S: AsRef<str>>(&mut self, cells: impl IntoIterator<Item = S>) {
        let before = self.text.len();
        let n = self.push(cells);
        assert_eq!(
            n,
            self.columns,
            "a row of {n} cells in a table of {} columns: {}",
            self.columns,
            &self.text[before..]
        );
    }

    /// Writes a row; returns its cell count.
    fn push<S: AsRef<str>>(&mut self, cells: impl IntoIterator<Item = S>) -> usize {
        self.text.push('|');
        let mut n = 0;
        for c in cells {
            let c = c.as_ref();
            if !c.is_empty() {
                self.text.push(' ');
                self.text.push_str(&c.replace('|', "/"));
            }
            self.text.push_str(" |");
            n += 1;
        }
        self.text.push('\n');
        n
    }

    /// The table's text, each row ending in a newline.
    #[must_use]
    pub fn finish(self) -> String {
        self.text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_cells_alignment_and_escapes_are_spelled_one_way() {
        let mut t = Table::new([("layout", Align::Left), ("B/sample", Align::Right), ("", Align::Left)]);
        t.row(["fat-20", "20", ""]);
        t.row(["a|b".to_string(), "1.5".into(), "yes".into()]);
        assert_eq!(t.finish(), "| layout | B/sample | |\n|---|--:|---|\n| fat-20 | 20 | |\n| a/b | 1.5 | yes |\n");
    }

    #[test]
    #[should_panic(expected = "a row of 1 cells in a table of 2 columns")]
    fn a_row_of_the_wrong_width_is_a_bug() {
        Table::new([("a", Align::Left), ("b", Align::Left)]).row(["x"]);
    }
}
