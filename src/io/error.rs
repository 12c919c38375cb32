use std::fmt;

/// Bad input: names the source (file), the line (1-based) and the field when known.
///
/// Displayed on one line, e.g. `data.csv line 12, column 'y': not a number: "abc"`.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    /// The file (or other source) the input came from.
    pub source_name: String,
    /// 1-based line number, when the problem sits on one line.
    pub line: Option<usize>,
    /// The field, column or JSON key concerned.
    pub field: Option<String>,
    /// What is wrong and what was expected.
    pub message: String,
}

impl InputError {
    /// An error about the whole source.
    pub fn new(source_name: &str, message: impl Into<String>) -> Self {
        Self {
            source_name: source_name.to_owned(),
            line: None,
            field: None,
            message: message.into(),
        }
    }

    /// Attaches a 1-based line number.
    pub fn at_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }

    /// Attaches the field (column name, JSON key) concerned.
    pub fn in_field(mut self, field: impl Into<String>) -> Self {
        self.field = Some(field.into());
        self
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.source_name)?;
        if let Some(line) = self.line {
            write!(f, " line {line}")?;
        }
        if let Some(field) = &self.field {
            if self.line.is_some() {
                write!(f, ", field '{field}'")?;
            } else {
                write!(f, " field '{field}'")?;
            }
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for InputError {}
