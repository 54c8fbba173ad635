//! Empty: it exists so that cargo resolves this package's build
//! dependencies (and so unifies the features of the proc macros' `syn`).

fn main() {}
