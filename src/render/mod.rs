//! A thin renderer on top of Embree.
