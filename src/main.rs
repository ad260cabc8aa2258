fn main() {
    println!("deformlab");
}
