pub mod browser;
pub mod studio;
