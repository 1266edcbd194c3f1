fn main() {
    println!("jogterm: under construction");
}
