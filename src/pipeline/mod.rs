//! Glue that joins two domains (layer L3, above `io`, `preset` and `plot`): each module reads its
//! inputs through `io`, builds the inputs of one domain from the outputs of another, and returns
//! typed results for the binary to print or stage. No domain imports another; they meet here.

pub mod acquisition;
