//! Python bindings for flc (work in progress; see issue 5).
