//! Integration of a normal field into depth (to be written).
