pub mod studio;
