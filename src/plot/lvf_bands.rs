//! Charts of solved LVF band transmissions (filled next).
