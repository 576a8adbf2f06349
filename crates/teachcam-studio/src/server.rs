//! The studio's web server.
